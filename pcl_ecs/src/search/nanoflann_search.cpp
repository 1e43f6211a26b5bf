#include <pcl_ecs/search/nanoflann_search.h>

#include <algorithm>
#include <cmath>

#include <nanoflann.hpp>
#include <pcl/common/point_tests.h>

namespace pcl_ecs
{

namespace
{
/// nanoflann's view of the points: a packed copy of x, y, z (cache-friendly, subset-aware).
struct Packed
{
  std::vector<float> xyz;
  std::size_t kdtree_get_point_count() const { return xyz.size() / 3; }
  float kdtree_get_pt(std::size_t i, std::size_t d) const { return xyz[3 * i + d]; }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const
  {
    return false;
  }
};
using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Packed>,
                                                 Packed, 3, std::uint32_t>;
}  // namespace

struct NanoflannSearch::Impl
{
  Packed points;
  std::vector<int> to_cloud;  // tree index -> cloud index
  std::unique_ptr<Tree> tree;
};

NanoflannSearch::NanoflannSearch(bool sorted)
  : pcl::search::Search<pcl::PointXYZ>("NanoflannSearch", sorted), impl_(std::make_unique<Impl>())
{
}

NanoflannSearch::~NanoflannSearch() = default;

void NanoflannSearch::setInputCloud(const PointCloudConstPtr& cloud, const IndicesConstPtr& indices)
{
  input_ = cloud;
  indices_ = indices;
  impl_->tree.reset();
  impl_->points.xyz.clear();
  impl_->to_cloud.clear();
  auto add = [&](int i) {
    const pcl::PointXYZ& p = (*cloud)[static_cast<std::size_t>(i)];
    if (!pcl::isFinite(p))
      return;
    impl_->points.xyz.insert(impl_->points.xyz.end(), {p.x, p.y, p.z});
    impl_->to_cloud.push_back(i);
  };
  if (indices)
    for (const auto i : *indices)
      add(i);
  else
    for (std::size_t i = 0; i < cloud->size(); ++i)
      add(static_cast<int>(i));
  impl_->tree = std::make_unique<Tree>(3, impl_->points, nanoflann::KDTreeSingleIndexAdaptorParams(40));
  impl_->tree->buildIndex();
}

int NanoflannSearch::nearestKSearch(const pcl::PointXYZ& point, int k, pcl::Indices& k_indices,
                                    std::vector<float>& k_sqr_distances) const
{
  k_indices.clear();
  k_sqr_distances.clear();
  if (!impl_->tree || k <= 0)
    return 0;
  const std::size_t want = std::min<std::size_t>(static_cast<std::size_t>(k), impl_->to_cloud.size());
  std::vector<std::uint32_t> idx(want);
  k_sqr_distances.resize(want);
  const float q[3] = {point.x, point.y, point.z};
  const std::size_t found = impl_->tree->knnSearch(q, want, idx.data(), k_sqr_distances.data());
  k_indices.resize(found);
  k_sqr_distances.resize(found);
  for (std::size_t i = 0; i < found; ++i)
    k_indices[i] = impl_->to_cloud[idx[i]];
  return static_cast<int>(found);
}

int NanoflannSearch::radiusSearch(const pcl::PointXYZ& point, double radius, pcl::Indices& k_indices,
                                  std::vector<float>& k_sqr_distances, unsigned int max_nn) const
{
  k_indices.clear();
  k_sqr_distances.clear();
  if (!impl_->tree || !(radius >= 0.0))
    return 0;
  // One buffer per thread, kept from call to call: growing a fresh one was a large part of a query.
  thread_local std::vector<std::pair<std::uint32_t, float>> matches;
  const float q[3] = {point.x, point.y, point.z};
  nanoflann::SearchParams params;
  params.sorted = sorted_results_ || max_nn > 0;
  impl_->tree->radiusSearch(q, static_cast<float>(radius * radius), matches, params);
  if (max_nn > 0 && matches.size() > max_nn)
    matches.resize(max_nn);
  k_indices.resize(matches.size());
  k_sqr_distances.resize(matches.size());
  for (std::size_t i = 0; i < matches.size(); ++i)
  {
    k_indices[i] = impl_->to_cloud[matches[i].first];
    k_sqr_distances[i] = matches[i].second;
  }
  return static_cast<int>(matches.size());
}

}  // namespace pcl_ecs
