// nanoflann_search.h — a pcl::search::Search<pcl::PointXYZ> back end built on nanoflann (Debian's
// libnanoflann-dev): the same interface as pcl::search::KdTree, about twice as fast for the many
// small K-nearest and radius queries of the method. Distances are SQUARED, as everywhere in PCL.
#pragma once

#include <memory>

#include <pcl/point_types.h>
#include <pcl/search/search.h>

namespace pcl_ecs
{

/** \brief K-d tree search with nanoflann behind PCL's search interface (PointXYZ only).
 * setInputCloud(cloud, indices) builds over the indexed subset; results are indices into the
 * cloud, as with pcl::search::KdTree. Queries are const and safe from several threads. */
class NanoflannSearch : public pcl::search::Search<pcl::PointXYZ>
{
public:
  using Ptr = std::shared_ptr<NanoflannSearch>;

  /** \param[in] sorted sort results by increasing distance (K-nearest results always are). */
  explicit NanoflannSearch(bool sorted = false);
  ~NanoflannSearch() override;

  void setInputCloud(const PointCloudConstPtr& cloud,
                     const IndicesConstPtr& indices = IndicesConstPtr()) override;

  int nearestKSearch(const pcl::PointXYZ& point, int k, pcl::Indices& k_indices,
                     std::vector<float>& k_sqr_distances) const override;

  int radiusSearch(const pcl::PointXYZ& point, double radius, pcl::Indices& k_indices,
                   std::vector<float>& k_sqr_distances, unsigned int max_nn = 0) const override;

  using pcl::search::Search<pcl::PointXYZ>::nearestKSearch;
  using pcl::search::Search<pcl::PointXYZ>::radiusSearch;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pcl_ecs
