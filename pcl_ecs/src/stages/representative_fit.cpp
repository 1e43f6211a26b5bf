#include <pcl_ecs/stages/representative_fit.h>

#include <pcl_ecs/stages/kernel.h>
#include <pcl_ecs/stages/tangent_frame.h>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>

namespace pcl_ecs
{

namespace
{
using Vector6 = Eigen::Matrix<double, 6, 1>;

/// The quadratic's monomials (1, u, v, u², uv, v²) at an offset, (u, v) its tangent coordinates in
/// the centre's frame (tangent_frame.h) in radii: the fit's basis and its height, in one place.
/// Radii keep the normal equations well scaled whatever the units.
class QuadraticBasis
{
public:
  QuadraticBasis(const Eigen::Vector3d& normal, double radius) : radius_(radius) { tangentFrame(normal, t1_, t2_); }
  Vector6 operator()(const Eigen::Vector3d& o) const
  {
    const double u = t1_.dot(o) / radius_, v = t2_.dot(o) / radius_;
    return (Vector6() << 1.0, u, v, u * u, u * v, v * v).finished();
  }

private:
  double radius_;
  Eigen::Vector3d t1_, t2_;
};

/// x moved along the normal to `height`: its tangent position at that height.
Eigen::Vector3d atHeight(const Eigen::Vector3d& x, const Eigen::Vector3d& normal, double height)
{
  return tangentPosition(x, normal) + height * normal;
}

/// The weighted least-squares quadratic of fitRepresentativeHeight and fitLocalHeight: `weight(j)`
/// gives member j's weight; at least `least_weighed` members must weigh more than 0.
template <class Weight>
std::optional<RepresentativeFit> fitHeight(const std::vector<Eigen::Vector3d>& offsets, double radius,
                                           const Eigen::Vector3d& normal, const Eigen::Vector3d& x,
                                           std::size_t least_weighed, Weight weight)
{
  if (offsets.size() < kRepresentativeFitMinPoints || !(radius > 0.0))
    return std::nullopt;
  const QuadraticBasis basis(normal, radius);
  Eigen::Matrix<double, 6, 6> normal_matrix = Eigen::Matrix<double, 6, 6>::Zero();
  Vector6 rhs = Vector6::Zero();
  double height_sq = 0.0;  // Σ g h²: with the normal equations, the fit's residual
  std::size_t weighed = 0;
  for (std::size_t j = 0; j < offsets.size(); ++j)
  {
    const double g = weight(j);
    if (!(g > 0.0))
      continue;
    ++weighed;
    const Vector6 phi = basis(offsets[j]);
    const double h = normal.dot(offsets[j]);
    normal_matrix.noalias() += g * phi * phi.transpose();
    rhs += (g * h) * phi;
    height_sq += g * h * h;
  }
  if (weighed < least_weighed)
    return std::nullopt;
  Eigen::ColPivHouseholderQR<Eigen::Matrix<double, 6, 6>> qr(normal_matrix);
  qr.setThreshold(1e-10);
  if (qr.rank() < 6)
    return std::nullopt;
  const Vector6 k = qr.solve(rhs);
  const double height = k.dot(basis(x));
  if (!std::isfinite(height) || !(std::abs(height) < radius))
    return std::nullopt;
  RepresentativeFit fit;
  fit.offset = atHeight(x, normal, height);
  fit.coefficients = k;
  // Σ g (h − φᵀk)² = Σ g h² − kᵀ rhs at the least-squares k; Σ g is the (0, 0) entry.
  fit.residual = std::sqrt(std::max(0.0, height_sq - k.dot(rhs)) / normal_matrix(0, 0)) / radius;
  return fit;
}
}  // namespace

bool smoothQuadric(const Quadric& q, double cutoff)
{
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(q.A, Eigen::EigenvaluesOnly);
  const double largest = es.eigenvalues()(2);
  return largest > 0.0 && es.eigenvalues()(1) < cutoff * largest;
}

std::optional<RepresentativeFit> fitRepresentativeHeight(const std::vector<Eigen::Vector3d>& offsets,
                                                       const std::vector<double>& distances, double radius,
                                                       const Eigen::Vector3d& normal, const Eigen::Vector3d& x)
{
  return fitHeight(offsets, radius, normal, x, 0, [&](std::size_t j) { return kernelG(distances[j], radius); });
}

std::optional<RepresentativeFit> fitLocalHeight(const std::vector<Eigen::Vector3d>& offsets, double radius,
                                                const Eigen::Vector3d& normal, const Eigen::Vector3d& x,
                                                double support)
{
  if (!(support > 0.0))
    return std::nullopt;
  const Eigen::Vector3d at = tangentPosition(x, normal);
  return fitHeight(offsets, radius, normal, x, kRepresentativeFitMinPoints, [&](std::size_t j) {
    return kernelG((tangentPosition(offsets[j], normal) - at).norm(), support);
  });
}

Eigen::Vector3d onFittedHeight(const Eigen::Matrix<double, 6, 1>& k, double radius, const Eigen::Vector3d& normal,
                               const Eigen::Vector3d& x)
{
  return atHeight(x, normal, k.dot(QuadraticBasis(normal, radius)(x)));
}

}  // namespace pcl_ecs
