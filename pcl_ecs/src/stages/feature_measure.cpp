#include <pcl_ecs/stages/feature_measure.h>

#include <cmath>
#include <cstddef>

namespace pcl_ecs
{

void computeFeatureMeasure(const LocalCloud& cloud, const NormalList& normals,
                           const NeighborhoodTable& table, int threads,
                           std::vector<double>& measure)
{
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(table.size());
  measure.assign(static_cast<std::size_t>(n), 0.0);
#pragma omp parallel for num_threads(threads) schedule(static)
  for (std::ptrdiff_t i = 0; i < n; ++i)
  {
    const Eigen::Vector3d p = cloud[i].getVector3fMap().cast<double>();
    const Eigen::Vector3d np = normals[static_cast<std::size_t>(i)].cast<double>();
    const int* nb = table.neighbors(static_cast<std::size_t>(i));
    double sum = 0.0;
    for (int j = 0; j < table.k; ++j)
      sum += std::abs((p - cloud[nb[j]].getVector3fMap().cast<double>()).dot(np));
    measure[static_cast<std::size_t>(i)] = sum / table.k;
  }
}

std::size_t classifyFeatures(const std::vector<double>& measure, double delta,
                             std::vector<std::uint8_t>& is_feature)
{
  is_feature.assign(measure.size(), 0);
  std::size_t count = 0;
  for (std::size_t i = 0; i < measure.size(); ++i)
    if (measure[i] > delta)
    {
      is_feature[i] = 1;
      ++count;
    }
  return count;
}

}  // namespace pcl_ecs
