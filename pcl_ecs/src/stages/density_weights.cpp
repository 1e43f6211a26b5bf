#include <pcl_ecs/stages/density_weights.h>

#include <algorithm>
#include <cstddef>

namespace pcl_ecs
{

void computeDensityWeights(const LocalCloud& cloud, const NeighborhoodTable& table, std::vector<double>& weights,
                           int threads)
{
  const auto n = static_cast<std::ptrdiff_t>(table.size());
  weights.assign(table.size(), 0.0);
#pragma omp parallel for num_threads(std::max(1, threads)) schedule(static)
  for (std::ptrdiff_t i = 0; i < n; ++i)
  {
    const int* nb = table.neighbors(static_cast<std::size_t>(i));
    double sum = 0.0;
    for (int j = 0; j < table.k; ++j)
      sum += sqrDistance(cloud, static_cast<std::size_t>(i), static_cast<std::size_t>(nb[j]));
    weights[static_cast<std::size_t>(i)] = sum / table.k;
  }
}

}  // namespace pcl_ecs
