#include <pcl_ecs/stages/feature_thinning.h>

#include "../detail/point_grid.h"

#include <algorithm>
#include <numeric>

namespace pcl_ecs
{

std::size_t thinFeatures(const LocalCloud& cloud, const std::vector<std::uint8_t>& is_feature,
                         const std::vector<double>& measure, double radius, std::vector<std::int64_t>& kept_by)
{
  kept_by.assign(cloud.size(), -1);
  std::vector<std::int64_t> order;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (is_feature[i])
      order.push_back(static_cast<std::int64_t>(i));
  if (!(radius > 0.0))
  {
    for (const std::int64_t i : order)
      kept_by[static_cast<std::size_t>(i)] = i;
    return order.size();
  }
  std::stable_sort(order.begin(), order.end(), [&](std::int64_t a, std::int64_t b) {
    return measure[static_cast<std::size_t>(a)] > measure[static_cast<std::size_t>(b)];
  });
  auto position = [&](std::int64_t i) {
    return Eigen::Vector3d(cloud[static_cast<std::size_t>(i)].getVector3fMap().cast<double>());
  };
  PointGrid kept(radius);
  std::size_t count = 0;
  for (const std::int64_t i : order)
    if (!kept.near(position(i), radius))
    {
      kept.insert(position(i), i);
      kept_by[static_cast<std::size_t>(i)] = i;
      ++count;
    }
  // Each dropped one to the nearest kept one (the one that dropped it, or one kept after it).
  for (const std::int64_t i : order)
    if (kept_by[static_cast<std::size_t>(i)] < 0)
      kept_by[static_cast<std::size_t>(i)] = kept.nearest(position(i), radius);
  return count;
}

}  // namespace pcl_ecs
