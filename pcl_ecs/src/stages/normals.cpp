#include <pcl_ecs/stages/normals.h>

#include <cmath>
#include <cstddef>

#include <pcl/common/centroid.h>
#include <pcl/common/eigen.h>

namespace pcl_ecs
{

void estimateNormals(const LocalCloud& cloud, const NeighborhoodTable& table, int threads,
                     NormalList& normals)
{
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(table.size());
  normals.assign(static_cast<std::size_t>(n), Eigen::Vector3f::UnitZ());
#pragma omp parallel num_threads(threads)
  {
    pcl::Indices hood(static_cast<std::size_t>(table.k) + 1);
#pragma omp for schedule(dynamic, 2048)
    for (std::ptrdiff_t i = 0; i < n; ++i)
    {
      hood[0] = static_cast<int>(i);
      const int* nb = table.neighbors(static_cast<std::size_t>(i));
      for (int j = 0; j < table.k; ++j)
        hood[j + 1] = nb[j];
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      Eigen::Vector4d mean = Eigen::Vector4d::Zero();
      // Normalised covariance around the mean (eq. 2 with p̄ the mean).
      if (pcl::computeMeanAndCovarianceMatrix(cloud, hood, cov, mean) == 0 || !cov.allFinite() ||
          cov.trace() <= 0.0)
        continue;  // all points identical: keep the arbitrary default normal
      double eigenvalue = 0.0;
      Eigen::Vector3d eigenvector;
      pcl::eigen33(cov, eigenvalue, eigenvector);
      const double len = eigenvector.norm();
      if (std::isfinite(len) && len > 0.0)
        normals[static_cast<std::size_t>(i)] = (eigenvector / len).cast<float>();
    }
  }
}

Status normalizeInputNormals(NormalList& normals, std::size_t& bad_index)
{
  for (std::size_t i = 0; i < normals.size(); ++i)
  {
    const float len = normals[i].norm();
    if (!std::isfinite(len) || len < 1e-12f)
    {
      bad_index = i;
      return Status::BadNormals;
    }
    normals[i] /= len;
  }
  return Status::Ok;
}

}  // namespace pcl_ecs
