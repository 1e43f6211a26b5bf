#include <pcl_ecs/neighborhood.h>

#include <algorithm>
#include <utility>

namespace pcl_ecs
{

Status computeNeighborhoods(const LocalCloud& cloud, const pcl::search::Search<pcl::PointXYZ>& search,
                            int k, int threads, NeighborhoodTable& table)
{
  table = NeighborhoodTable{};
  if (k < 1)
    return Status::InvalidArgument;
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(cloud.size());
  if (n <= k)
    return Status::TooFewPoints;
  table.k = k;
  table.indices.assign(static_cast<std::size_t>(n) * k, 0);
  table.sqr_distances.assign(static_cast<std::size_t>(n) * k, 0.f);

#pragma omp parallel num_threads(threads)
  {
    pcl::Indices found;
    std::vector<float> d2;
    std::vector<std::pair<float, int>> row;
#pragma omp for schedule(dynamic, 2048)
    for (std::ptrdiff_t i = 0; i < n; ++i)
    {
      // k + 1 because the point finds itself (or a duplicate of itself) first, + 1 to see past
      // the k-th distance: when points tie at that distance, which of them a back end returns
      // depends on its tree, so ask for more until every tied point is in (then the smallest
      // indices win, whatever the tree: a tile of the out-of-core path and the whole cloud agree).
      int ask = k + 2;
      for (;;)
      {
        search.nearestKSearch(cloud[i], std::min<int>(ask, static_cast<int>(n)), found, d2);
        row.clear();
        bool self_seen = false;
        for (std::size_t j = 0; j < found.size(); ++j)
        {
          if (!self_seen && found[j] == i)
          {
            self_seen = true;
            continue;
          }
          row.emplace_back(d2[j], found[j]);
        }
        std::sort(row.begin(), row.end());  // distance, then index: independent of the back end
        const bool complete = static_cast<std::ptrdiff_t>(found.size()) < ask || ask >= n ||
                              row.size() <= static_cast<std::size_t>(k) ||
                              row.back().first > row[static_cast<std::size_t>(k) - 1].first;
        if (complete && self_seen)
          break;
        if (ask >= n)
          break;
        ask = static_cast<int>(std::min<std::ptrdiff_t>(n, 2 * static_cast<std::ptrdiff_t>(ask)));
      }
      row.resize(std::min<std::size_t>(row.size(), static_cast<std::size_t>(k)));
      // A back end may return fewer than k + 1 (it should not with n > k); repeat the last.
      while (row.size() < static_cast<std::size_t>(k))
        row.push_back(row.empty() ? std::make_pair(0.f, static_cast<int>(i)) : row.back());
      int* out_i = table.indices.data() + i * k;
      float* out_d = table.sqr_distances.data() + i * k;
      for (int j = 0; j < k; ++j)
      {
        out_i[j] = row[j].second;
        out_d[j] = row[j].first;
      }
    }
  }
  return Status::Ok;
}

}  // namespace pcl_ecs
