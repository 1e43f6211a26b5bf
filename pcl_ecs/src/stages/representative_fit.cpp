#include <pcl_ecs/stages/representative_fit.h>

#include <pcl_ecs/stages/kernel.h>
#include <pcl_ecs/stages/tangent_frame.h>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>

namespace pcl_ecs
{

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
  if (offsets.size() < kRepresentativeFitMinPoints || !(radius > 0.0))
    return std::nullopt;
  Eigen::Vector3d t1, t2;
  tangentFrame(normal, t1, t2);
  // Tangent coordinates in radii keep the normal equations well scaled whatever the units.
  using Vector6 = Eigen::Matrix<double, 6, 1>;
  auto basis = [&](const Eigen::Vector3d& o) {
    const double u = t1.dot(o) / radius, v = t2.dot(o) / radius;
    return (Vector6() << 1.0, u, v, u * u, u * v, v * v).finished();
  };
  Eigen::Matrix<double, 6, 6> normal_matrix = Eigen::Matrix<double, 6, 6>::Zero();
  Vector6 rhs = Vector6::Zero();
  double height_sq = 0.0;  // Σ g h²: with the normal equations, the fit's residual
  for (std::size_t j = 0; j < offsets.size(); ++j)
  {
    const double g = kernelG(distances[j], radius);
    const Vector6 phi = basis(offsets[j]);
    const double h = normal.dot(offsets[j]);
    normal_matrix.noalias() += g * phi * phi.transpose();
    rhs += (g * h) * phi;
    height_sq += g * h * h;
  }
  Eigen::ColPivHouseholderQR<Eigen::Matrix<double, 6, 6>> qr(normal_matrix);
  qr.setThreshold(1e-10);
  if (qr.rank() < 6)
    return std::nullopt;
  const Vector6 k = qr.solve(rhs);
  const double height = k.dot(basis(x));
  if (!std::isfinite(height) || !(std::abs(height) < radius))
    return std::nullopt;
  RepresentativeFit fit;
  fit.offset = x - normal.dot(x) * normal + height * normal;
  fit.coefficients = k;
  // Σ g (h − φᵀk)² = Σ g h² − kᵀ rhs at the least-squares k; Σ g is the (0, 0) entry.
  fit.residual = std::sqrt(std::max(0.0, height_sq - k.dot(rhs)) / normal_matrix(0, 0)) / radius;
  return fit;
}

Eigen::Vector3d onFittedHeight(const Eigen::Matrix<double, 6, 1>& k, double radius, const Eigen::Vector3d& normal,
                               const Eigen::Vector3d& x)
{
  Eigen::Vector3d t1, t2;
  tangentFrame(normal, t1, t2);
  const double u = t1.dot(x) / radius, v = t2.dot(x) / radius;
  const double height = k(0) + k(1) * u + k(2) * v + k(3) * u * u + k(4) * u * v + k(5) * v * v;
  return x - normal.dot(x) * normal + height * normal;
}

}  // namespace pcl_ecs
