#include <pcl_ecs/stages/local_density.h>

#include <algorithm>
#include <cmath>
#include <cstddef>

namespace pcl_ecs
{

void computeLocalDensity(const LocalCloud& cloud, const NeighborhoodTable& table,
                         const std::vector<std::uint8_t>& is_feature,
                         const pcl::search::Search<pcl::PointXYZ>& search,
                         int threads, std::vector<double>& dens)
{
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(table.size());
  dens.assign(static_cast<std::size_t>(n), 0.0);
#pragma omp parallel num_threads(threads)
  {
    pcl::Indices found;
    std::vector<float> d2;
#pragma omp for schedule(dynamic, 4096)
    for (std::ptrdiff_t i = 0; i < n; ++i)
    {
      if (is_feature[static_cast<std::size_t>(i)])
        continue;
      const int* nb = table.neighbors(static_cast<std::size_t>(i));
      double best = -1.0;
      for (int j = 0; j < table.k; ++j)
        if (!is_feature[static_cast<std::size_t>(nb[j])])
        {
          // sorted: the first non-feature neighbour is the nearest
          best = sqrDistance(cloud, static_cast<std::size_t>(i), static_cast<std::size_t>(nb[j]));
          break;
        }
      // Every K-neighbour is a feature point: ask for more until a non-feature point shows (the
      // smallest distance among those is the answer, whichever of tied points the search returns).
      for (std::ptrdiff_t ask = 4 * static_cast<std::ptrdiff_t>(table.k); best < 0.0; ask *= 2)
      {
        const int want = static_cast<int>(std::min<std::ptrdiff_t>(ask, n));
        search.nearestKSearch(cloud[i], want, found, d2);
        for (std::size_t j = 0; j < found.size(); ++j)
          if (found[j] != i && !is_feature[static_cast<std::size_t>(found[j])] && (best < 0.0 || d2[j] < best))
            best = d2[j];
        if (want >= n)
          break;
      }
      if (best < 0.0)
        best = 0.0;  // the only non-feature point: no spacing to speak of
      dens[static_cast<std::size_t>(i)] = std::sqrt(best);
    }
  }
}

}  // namespace pcl_ecs
