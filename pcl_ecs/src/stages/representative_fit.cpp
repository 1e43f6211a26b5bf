#include <pcl_ecs/stages/representative_fit.h>

#include <pcl_ecs/stages/kernel.h>
#include <pcl_ecs/stages/tangent_frame.h>

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

#include <cmath>

namespace pcl_ecs
{

bool smoothQuadric(const Quadric& q, double cutoff)
{
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(q.A, Eigen::EigenvaluesOnly);
  const double largest = es.eigenvalues()(2);
  return largest > 0.0 && es.eigenvalues()(1) < cutoff * largest;
}

std::optional<Eigen::Vector3d> fitRepresentativeHeight(const std::vector<Eigen::Vector3d>& offsets,
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
  for (std::size_t j = 0; j < offsets.size(); ++j)
  {
    const double g = kernelG(distances[j], radius);
    const Vector6 phi = basis(offsets[j]);
    normal_matrix.noalias() += g * phi * phi.transpose();
    rhs += (g * normal.dot(offsets[j])) * phi;
  }
  Eigen::ColPivHouseholderQR<Eigen::Matrix<double, 6, 6>> qr(normal_matrix);
  qr.setThreshold(1e-10);
  if (qr.rank() < 6)
    return std::nullopt;
  const Vector6 k = qr.solve(rhs);
  const double height = k.dot(basis(x));
  if (!std::isfinite(height) || !(std::abs(height) < radius))
    return std::nullopt;
  return Eigen::Vector3d(x - normal.dot(x) * normal + height * normal);
}

}  // namespace pcl_ecs
