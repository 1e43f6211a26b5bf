// neighborhood.h: the one K-neighbourhood query that serves eq. 1, 2, 3 and 7-12.
#pragma once

#include <pcl_ecs/types.h>

#include <cstddef>
#include <vector>

#include <pcl/search/search.h>

namespace pcl_ecs
{

/** \brief The K nearest neighbours of every point, the point itself excluded, sorted by
 * increasing distance (ties by index). Distances are SQUARED, in local-frame units. */
struct NeighborhoodTable
{
  int k = 0;
  /// size() * k entries, row i = neighbours of point i (filled row by row by the parallel search)
  std::vector<int, UninitialisedAllocator<int>> indices;
  std::vector<float, UninitialisedAllocator<float>> sqr_distances;  ///< same layout, squared distances

  std::size_t size() const { return k > 0 ? indices.size() / static_cast<std::size_t>(k) : 0; }
  const int* neighbors(std::size_t i) const { return indices.data() + i * k; }
  const float* sqrDistances(std::size_t i) const { return sqr_distances.data() + i * k; }
};

/** \brief Fill `table` with the K nearest neighbours of every point of `cloud` (itself excluded).
 * \param[in] cloud    the points; `search` must have been given this cloud with no indices
 * \param[in] search   a PCL search structure over `cloud` (any back end of pcl::search::Search)
 * \param[in] k        number of neighbours, 1 <= k < cloud.size()
 * \param[in] threads  worker threads (>= 1); the result does not depend on it
 * \param[out] table   the neighbourhoods
 * \return Status::TooFewPoints when cloud.size() <= k. */
Status computeNeighborhoods(const LocalCloud& cloud, const pcl::search::Search<pcl::PointXYZ>& search,
                            int k, int threads, NeighborhoodTable& table);

}  // namespace pcl_ecs
