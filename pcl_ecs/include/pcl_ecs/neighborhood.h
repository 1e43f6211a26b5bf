// neighborhood.h: the one K-neighbourhood query that serves eq. 1, 2, 3 and 7-12.
#pragma once

#include <pcl_ecs/types.h>

#include <cstddef>
#include <memory>
#include <vector>

#include <pcl/search/search.h>

namespace pcl_ecs
{

/** \brief The K nearest neighbours of every point, the point itself excluded, sorted by
 * increasing distance (ties by index). Only the indices are stored (4 bytes a neighbour): a
 * distance is one sqrDistance() away, bit for bit the value the search ranked by. */
struct NeighborhoodTable
{
  int k = 0;

  /// Make room for n rows of k neighbours, left unwritten: every row is then written once, by the
  /// thread that answers it (no zeroing pass by one thread before).
  void allocate(std::size_t n, int neighbours)
  {
    k = neighbours;
    rows_ = n;
    entries_.reset(n > 0 && neighbours > 0 ? new int[n * static_cast<std::size_t>(neighbours)] : nullptr);
  }
  std::size_t size() const { return rows_; }
  const int* neighbors(std::size_t i) const { return entries_.get() + i * static_cast<std::size_t>(k); }
  int* row(std::size_t i) { return entries_.get() + i * static_cast<std::size_t>(k); }

private:
  std::size_t rows_ = 0;
  std::unique_ptr<int[]> entries_;  ///< rows_ * k entries, row i = neighbours of point i
};

/** \brief The squared distance between points a and b of the cloud, in float, computed as the
 * K-neighbour search and the box tree compute it (the table is ranked by exactly these values). */
inline float sqrDistance(const LocalCloud& cloud, std::size_t a, std::size_t b)
{
  const float dx = cloud[a].x - cloud[b].x, dy = cloud[a].y - cloud[b].y, dz = cloud[a].z - cloud[b].z;
  return dx * dx + dy * dy + dz * dz;
}

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
