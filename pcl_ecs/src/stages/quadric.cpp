#include <pcl_ecs/stages/quadric.h>

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>

namespace pcl_ecs
{

QuadricMinimum minimizeQuadric(const Quadric& q, double relative_cutoff)
{
  QuadricMinimum out;
  if (!(q.weight_sum > 0.0))
    return out;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(q.A);
  const Eigen::Vector3d& lambda = es.eigenvalues();  // ascending
  const double lambda_max = lambda(2);
  if (lambda_max > 0.0 && std::isfinite(lambda_max))
  {
    for (int i = 0; i < 3; ++i)
    {
      if (lambda(i) <= relative_cutoff * lambda_max)
        continue;
      const Eigen::Vector3d u = es.eigenvectors().col(i);
      out.x += (u.dot(q.b) / lambda(i)) * u;
      ++out.rank;
    }
  }
  out.value = std::max(0.0, q.evaluate(out.x));
  return out;
}

}  // namespace pcl_ecs
