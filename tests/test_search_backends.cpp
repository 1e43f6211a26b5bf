// The search back ends (nanoflann's K-d tree, the box tree over runs of points) against brute
// force, through PCL's search interface.
#include <pcl_ecs/search/box_tree_search.h>
#include <pcl_ecs/search/nanoflann_search.h>
#include <pcl_ecs/spatial_order.h>

#include "detail/simd.h"  // private: switch the AVX2 loops off and on
#include "synthetic_shapes.h"

#include <algorithm>
#include <cstring>

#include <gtest/gtest.h>

using namespace pcl_ecs_test;

namespace
{
std::vector<std::pair<float, int>> bruteForce(const Cloud& c, const pcl::PointXYZ& q, const pcl::Indices* subset)
{
  std::vector<std::pair<float, int>> all;
  auto add = [&](int i) { all.emplace_back((c[i].getVector3fMap() - q.getVector3fMap()).squaredNorm(), i); };
  if (subset)
    for (int i : *subset)
      add(i);
  else
    for (int i = 0; i < static_cast<int>(c.size()); ++i)
      add(i);
  std::sort(all.begin(), all.end());
  return all;
}
}  // namespace

template <class Search>
class SearchBackend : public ::testing::Test
{
};
using Backends = ::testing::Types<pcl_ecs::NanoflannSearch, pcl_ecs::BoxTreeSearch>;
TYPED_TEST_SUITE(SearchBackend, Backends);

TYPED_TEST(SearchBackend, KNearestAndRadiusMatchBruteForce)
{
  Rng rng(17);
  auto cloud = std::make_shared<Cloud>();
  for (int i = 0; i < 2000; ++i)
    cloud->push_back(toPoint({rng.uniform(), rng.uniform(), rng.uniform()}));
  auto subset = std::make_shared<pcl::Indices>();
  for (int i = 0; i < 2000; i += 3)
    subset->push_back(i);
  for (bool use_subset : {false, true})
  {
    TypeParam search;
    search.setInputCloud(cloud, use_subset ? subset : nullptr);
    for (int q = 0; q < 50; ++q)
    {
      const pcl::PointXYZ query = toPoint({rng.uniform(), rng.uniform(), rng.uniform()});
      const auto truth = bruteForce(*cloud, query, use_subset ? subset.get() : nullptr);
      pcl::Indices idx;
      std::vector<float> d2;
      ASSERT_EQ(search.nearestKSearch(query, 12, idx, d2), 12);
      for (int j = 0; j < 12; ++j)
      {
        EXPECT_EQ(idx[static_cast<std::size_t>(j)], truth[static_cast<std::size_t>(j)].second);
        EXPECT_NEAR(d2[static_cast<std::size_t>(j)], truth[static_cast<std::size_t>(j)].first, 1e-6f);
      }
      const double radius = 0.1;
      search.radiusSearch(query, radius, idx, d2);
      std::size_t inside = 0;
      while (inside < truth.size() && truth[inside].first <= radius * radius)
        ++inside;
      ASSERT_EQ(idx.size(), inside);
      std::vector<int> got(idx.begin(), idx.end()), want;
      for (std::size_t j = 0; j < inside; ++j)
        want.push_back(truth[j].second);
      std::sort(got.begin(), got.end());
      std::sort(want.begin(), want.end());
      EXPECT_EQ(got, want);
    }
  }
}

TEST(BoxTreeSearch, RadiusScanGivesTheSameResultsWithAndWithoutAvx2)
{
  // A run's points are scanned by a portable loop or, where the CPU has AVX2, eight at a time:
  // the same points, squared distances (bits) and order, and those of brute force. Queries of
  // every size, so that runs are wholly, partly and not at all within reach; the cloud's size is
  // no multiple of the run (a padded last run).
  Rng rng(29);
  auto cloud = std::make_shared<Cloud>();
  for (int i = 0; i < 3001; ++i)
    cloud->push_back(toPoint({rng.uniform(), rng.uniform(), 0.1 * rng.uniform()}));
  pcl_ecs::BoxTreeSearch search;
  search.setInputCloud(cloud);
  for (int q = 0; q < 60; ++q)
  {
    const pcl::PointXYZ query = toPoint({rng.uniform(), rng.uniform(), 0.05});
    const double radius = 0.01 * (q + 1);
    pcl::Indices portable_i, wide_i;
    std::vector<float> portable_d, wide_d;
    pcl_ecs::detail::allowAvx2(false);
    search.radiusSearch(query, radius, portable_i, portable_d);
    pcl_ecs::detail::allowAvx2(true);
    search.radiusSearch(query, radius, wide_i, wide_d);
    EXPECT_EQ(portable_i, wide_i) << "query " << q;
    ASSERT_EQ(portable_d.size(), wide_d.size());
    if (!portable_d.empty())  // (memcmp of two empty vectors' null data is undefined)
      EXPECT_EQ(0, std::memcmp(portable_d.data(), wide_d.data(), portable_d.size() * sizeof(float)));
    const auto truth = bruteForce(*cloud, query, nullptr);
    std::size_t inside = 0;
    while (inside < truth.size() && truth[inside].first <= static_cast<float>(radius * radius))
      ++inside;
    EXPECT_EQ(portable_i.size(), inside) << "query " << q;
  }
}

TYPED_TEST(SearchBackend, SortedRadiusResultsAndMaxNeighbours)
{
  auto cloud = gridPlane(20, 0.1);
  TypeParam search(true);
  search.setInputCloud(cloud);
  pcl::Indices idx;
  std::vector<float> d2;
  search.radiusSearch((*cloud)[210], 0.35, idx, d2);
  EXPECT_TRUE(std::is_sorted(d2.begin(), d2.end()));
  EXPECT_EQ(d2.front(), 0.0f);
  search.radiusSearch((*cloud)[210], 0.35, idx, d2, 5);
  EXPECT_EQ(idx.size(), 5u);
  EXPECT_FLOAT_EQ(d2.back(), 0.01f);  // the 4 grid neighbours at 0.1 after the point itself
}

TYPED_TEST(SearchBackend, SkipsNonFinitePoints)
{
  auto cloud = gridPlane(5, 1.0);
  (*cloud)[3].x = std::numeric_limits<float>::quiet_NaN();
  TypeParam search;
  search.setInputCloud(cloud);
  pcl::Indices idx;
  std::vector<float> d2;
  search.nearestKSearch((*cloud)[2], 25, idx, d2);
  EXPECT_EQ(idx.size(), 24u);
  EXPECT_EQ(std::count(idx.begin(), idx.end(), 3), 0);
}

// The box tree's own promises: exact (distance, index) order of K-nearest results, ties at the
// k-th distance resolved to the smallest indices; the same results in any point order (fast or
// not) and with any number of build threads; radius results in cloud order.
TEST(BoxTreeSearch, KNearestTiesKeepTheSmallestIndices)
{
  auto cloud = gridPlane(30, 0.5);  // every point has 4 neighbours at 0.5, 4 at 0.5·√2, ...
  pcl_ecs::BoxTreeSearch search;
  search.setInputCloud(cloud);
  pcl::Indices idx;
  std::vector<float> d2;
  for (int q : {0, 31, 465, 899})
  {
    const auto truth = bruteForce(*cloud, (*cloud)[static_cast<std::size_t>(q)], nullptr);
    for (int k : {1, 3, 5, 7, 9, 13, 100, 300})  // up to 64 a sorted array keeps them, beyond a heap
    {
      ASSERT_EQ(search.nearestKSearch((*cloud)[static_cast<std::size_t>(q)], k, idx, d2), k);
      for (int j = 0; j < k; ++j)
      {
        EXPECT_EQ(idx[static_cast<std::size_t>(j)], truth[static_cast<std::size_t>(j)].second) << q << " " << k;
        EXPECT_EQ(d2[static_cast<std::size_t>(j)], truth[static_cast<std::size_t>(j)].first);
      }
    }
  }
}

TEST(BoxTreeSearch, SameResultsInAnyOrderAndWithAnyThreads)
{
  Rng rng(5);
  auto cloud = std::make_shared<Cloud>();
  for (int i = 0; i < 20000; ++i)  // a noisy wavy sheet, the kind of cloud the filter sees
  {
    const double u = rng.uniform(), v = rng.uniform();
    cloud->push_back(toPoint({u, v, 0.05 * std::sin(9 * u) * std::cos(7 * v) + 0.002 * rng.normal()}));
  }
  std::vector<int> ids(cloud->size());
  for (std::size_t i = 0; i < ids.size(); ++i)
    ids[i] = static_cast<int>(i);
  pcl_ecs::sortBySpatialCode(
      ids, [&](int i) { return (*cloud)[static_cast<std::size_t>(i)].getVector3fMap().cast<double>(); },
      Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 1, 1), 1);
  auto sorted = std::make_shared<Cloud>();
  for (const int i : ids)
    sorted->push_back((*cloud)[static_cast<std::size_t>(i)]);
  pcl_ecs::BoxTreeSearch one(false, 1), two(false, 2), any_order(false, 2);
  one.setInputCloud(sorted);
  two.setInputCloud(sorted);
  any_order.setInputCloud(cloud);
  pcl::Indices a, b, c;
  std::vector<float> da, db, dc;
  for (int q = 0; q < 300; ++q)
  {
    const pcl::PointXYZ query = toPoint({rng.uniform(), rng.uniform(), 0.0});
    one.radiusSearch(query, 0.03, a, da);
    two.radiusSearch(query, 0.03, b, db);
    EXPECT_EQ(a, b);
    EXPECT_EQ(da, db);
    EXPECT_TRUE(std::is_sorted(a.begin(), a.end()));  // cloud order
    any_order.radiusSearch(query, 0.03, c, dc);
    EXPECT_EQ(c.size(), a.size());
    one.nearestKSearch(query, 16, a, da);
    two.nearestKSearch(query, 16, b, db);
    EXPECT_EQ(a, b);
    any_order.nearestKSearch(query, 16, c, dc);
    EXPECT_EQ(da, dc);  // the same distances whatever the order of the points
  }
}

TEST(BoxTreeSearch, EmptyAndDegenerateInputs)
{
  pcl_ecs::BoxTreeSearch search;
  auto empty = std::make_shared<Cloud>();
  search.setInputCloud(empty);
  pcl::Indices idx{7};
  std::vector<float> d2{1.f};
  EXPECT_EQ(search.nearestKSearch(toPoint({0, 0, 0}), 3, idx, d2), 0);
  EXPECT_TRUE(idx.empty());
  EXPECT_EQ(search.radiusSearch(toPoint({0, 0, 0}), 1.0, idx, d2), 0);
  auto same = std::make_shared<Cloud>();
  for (int i = 0; i < 40; ++i)
    same->push_back(toPoint({1, 2, 3}));
  search.setInputCloud(same);
  EXPECT_EQ(search.radiusSearch(toPoint({1, 2, 3}), 0.0, idx, d2), 40);
  ASSERT_EQ(search.nearestKSearch(toPoint({1, 2, 3}), 5, idx, d2), 5);
  EXPECT_EQ(idx, (pcl::Indices{0, 1, 2, 3, 4}));  // all tied: the smallest indices
  EXPECT_EQ(search.nearestKSearch(toPoint({1, 2, 3}), 100, idx, d2), 40);
  // A radius whose square overflows a float reaches everything (and no empty slot of the tree).
  EXPECT_EQ(search.radiusSearch(toPoint({0, 0, 0}), 1e30, idx, d2), 40);
  pcl::PointXYZ nan_query = toPoint({0, 0, 0});
  nan_query.x = std::numeric_limits<float>::quiet_NaN();
  EXPECT_EQ(search.radiusSearch(nan_query, 1.0, idx, d2), 0);
  EXPECT_EQ(search.nearestKSearch(nan_query, 3, idx, d2), 0);
}
