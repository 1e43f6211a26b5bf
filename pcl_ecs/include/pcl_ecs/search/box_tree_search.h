// box_tree_search.h — a pcl::search::Search<pcl::PointXYZ> back end for clouds whose points are
// already in a space-filling-curve order (the filter and the out-of-core tiles keep their points
// in Hilbert order): a tree of bounding boxes over runs of consecutive points. Building it is one
// parallel pass over the points (no sorting, no splitting); a query descends the boxes and scans
// the runs it reaches with vectorisable distance loops. Distances are SQUARED, as in PCL.
#pragma once

#include <memory>

#include <pcl/point_types.h>
#include <pcl/search/search.h>

namespace pcl_ecs
{

/** \brief Bounding-box tree over runs of consecutive points behind PCL's search interface
 * (PointXYZ only). Correct for any point order; fast when consecutive points are close (a
 * Hilbert-ordered cloud: see sortBySpatialCode). Non-finite points are skipped;
 * setInputCloud(cloud, indices) builds over the indexed subset. Queries are const and safe from
 * several threads.
 *
 * Results are exact and independent of the thread count: radiusSearch returns every point with
 * squared distance <= radius² (in the order of the cloud unless sorted results are asked for);
 * nearestKSearch returns the k smallest (squared distance, index) pairs, sorted, so that of points
 * tied at the k-th distance the smallest indices are kept. */
class BoxTreeSearch : public pcl::search::Search<pcl::PointXYZ>
{
public:
  using Ptr = std::shared_ptr<BoxTreeSearch>;

  /** \param[in] sorted sort radius results by increasing (distance, index)
   * \param[in] threads threads for building the tree (0: all cores) */
  explicit BoxTreeSearch(bool sorted = false, int threads = 0);
  ~BoxTreeSearch() override;

  void setInputCloud(const PointCloudConstPtr& cloud,
                     const IndicesConstPtr& indices = IndicesConstPtr()) override;

  int nearestKSearch(const pcl::PointXYZ& point, int k, pcl::Indices& k_indices,
                     std::vector<float>& k_sqr_distances) const override;

  int radiusSearch(const pcl::PointXYZ& point, double radius, pcl::Indices& k_indices,
                   std::vector<float>& k_sqr_distances, unsigned int max_nn = 0) const override;

  using pcl::search::Search<pcl::PointXYZ>::nearestKSearch;
  using pcl::search::Search<pcl::PointXYZ>::radiusSearch;

  /** \brief Points per run (leaf box). */
  static constexpr int kRun = 32;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int threads_;
};

}  // namespace pcl_ecs
