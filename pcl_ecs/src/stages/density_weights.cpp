#include <pcl_ecs/stages/density_weights.h>

namespace pcl_ecs
{

void computeDensityWeights(const NeighborhoodTable& table, std::vector<double>& weights)
{
  const std::size_t n = table.size();
  weights.assign(n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
  {
    const float* d2 = table.sqrDistances(i);
    double sum = 0.0;
    for (int j = 0; j < table.k; ++j)
      sum += d2[j];
    weights[i] = sum / table.k;
  }
}

}  // namespace pcl_ecs
