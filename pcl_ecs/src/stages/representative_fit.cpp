#include <pcl_ecs/stages/representative_fit.h>

#include <pcl_ecs/stages/kernel.h>
#include <pcl_ecs/stages/tangent_frame.h>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace pcl_ecs
{

namespace
{
using Vector6 = Eigen::Matrix<double, 6, 1>;

/// The monomials of a height field in the centre's tangent frame (tangent_frame.h), (u, v) an
/// offset's tangent coordinates in radii: 1, u, v, u², uv, v² (the quadratic, Terms = 6), then u³,
/// u²v, uv², v³ (the cubic, Terms = 10). Radii keep the normal equations well scaled whatever the
/// units.
template <int Terms>
class MonomialBasis
{
public:
  using Vector = Eigen::Matrix<double, Terms, 1>;
  MonomialBasis(const Eigen::Vector3d& normal, double radius) : radius_(radius) { tangentFrame(normal, t1_, t2_); }
  Vector operator()(const Eigen::Vector3d& o) const
  {
    const double u = t1_.dot(o) / radius_, v = t2_.dot(o) / radius_;
    Vector phi;
    phi.template head<6>() << 1.0, u, v, u * u, u * v, v * v;
    if constexpr (Terms == 10)
      phi.template tail<4>() << u * u * u, u * u * v, u * v * v, v * v * v;
    return phi;
  }

private:
  double radius_;
  Eigen::Vector3d t1_, t2_;
};
using QuadraticBasis = MonomialBasis<6>;

/// The weighted least-squares normal equations of the heights along `normal` over a basis:
/// Σ g φφᵀ, Σ g h φ, Σ g h² (with the solution, the residual), Σ g and Σ g² (the weights'
/// effective count), and how many members weigh more than 0.
template <int Terms>
struct NormalEquations
{
  Eigen::Matrix<double, Terms, Terms> matrix = Eigen::Matrix<double, Terms, Terms>::Zero();
  Eigen::Matrix<double, Terms, 1> rhs = Eigen::Matrix<double, Terms, 1>::Zero();
  double height_sq = 0.0, weight = 0.0, weight_sq = 0.0;
  std::size_t weighed = 0;
};

template <int Terms, class Weight>
NormalEquations<Terms> accumulate(const std::vector<Eigen::Vector3d>& offsets, const MonomialBasis<Terms>& basis,
                                  const Eigen::Vector3d& normal, Weight weight)
{
  NormalEquations<Terms> e;
  for (std::size_t j = 0; j < offsets.size(); ++j)
  {
    const double g = weight(j);
    if (!(g > 0.0))
      continue;
    ++e.weighed;
    const auto phi = basis(offsets[j]);
    const double h = normal.dot(offsets[j]);
    e.matrix.noalias() += g * phi * phi.transpose();
    e.rhs += (g * h) * phi;
    e.height_sq += g * h * h;
    e.weight += g;
    e.weight_sq += g * g;
  }
  return e;
}

/// The least-squares coefficients of `e` and their weighted sum of squared residuals,
/// Σ g (h − φᵀk)² = Σ g h² − kᵀ rhs; nothing when the matrix is rank-deficient.
template <int Terms>
std::optional<std::pair<Eigen::Matrix<double, Terms, 1>, double>> solve(const Eigen::Matrix<double, Terms, Terms>& matrix,
                                                                         const Eigen::Matrix<double, Terms, 1>& rhs,
                                                                         double height_sq)
{
  Eigen::ColPivHouseholderQR<Eigen::Matrix<double, Terms, Terms>> qr(matrix);
  qr.setThreshold(1e-10);
  if (qr.rank() < Terms)
    return std::nullopt;
  const Eigen::Matrix<double, Terms, 1> k = qr.solve(rhs);
  return std::pair{k, std::max(0.0, height_sq - k.dot(rhs))};
}

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
  const NormalEquations<6> e = accumulate(offsets, basis, normal, weight);
  if (e.weighed < least_weighed)
    return std::nullopt;
  const auto solved = solve<6>(e.matrix, e.rhs, e.height_sq);
  if (!solved)
    return std::nullopt;
  const Vector6& k = solved->first;
  const double height = k.dot(basis(x));
  if (!std::isfinite(height) || !(std::abs(height) < radius))
    return std::nullopt;
  RepresentativeFit fit;
  fit.offset = atHeight(x, normal, height);
  fit.coefficients = k;
  fit.residual = std::sqrt(solved->second / e.weight) / radius;
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

double cubicTermsF(const std::vector<Eigen::Vector3d>& offsets, const std::vector<double>& distances, double radius,
                   const Eigen::Vector3d& normal)
{
  if (!(radius > 0.0))
    return 0.0;
  const NormalEquations<10> e =
      accumulate(offsets, MonomialBasis<10>(normal, radius), normal, [&](std::size_t j) { return kernelG(distances[j], radius); });
  const double effective = e.weight_sq > 0.0 ? e.weight * e.weight / e.weight_sq : 0.0;
  if (!(effective >= kCubicTestMinPoints))
    return 0.0;
  // The quadratic is the cubic's first six terms: its normal equations are the top-left block.
  const auto cubic = solve<10>(e.matrix, e.rhs, e.height_sq);
  const auto quadratic =
      solve<6>(e.matrix.topLeftCorner<6, 6>(), e.rhs.head<6>(), e.height_sq);
  if (!cubic || !quadratic)
    return 0.0;
  const double gain = quadratic->second - cubic->second;
  // Rounding leaves the sums of an exact fit at about 1e-16 of Σ g h²: below that, no difference.
  const double floor = 1e-12 * e.height_sq;
  if (!(gain > floor))
    return 0.0;
  if (!(cubic->second > floor))
    return std::numeric_limits<double>::infinity();  // the cubic is exact, the quadratic is not
  return (gain / 4.0) / (cubic->second / (effective - 10.0));
}

Eigen::Vector3d onFittedHeight(const Eigen::Matrix<double, 6, 1>& k, double radius, const Eigen::Vector3d& normal,
                               const Eigen::Vector3d& x)
{
  return atHeight(x, normal, k.dot(QuadraticBasis(normal, radius)(x)));
}

}  // namespace pcl_ecs
