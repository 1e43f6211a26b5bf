// The nanoflann back end against brute force, through PCL's search interface.
#include <pcl_ecs/search/nanoflann_search.h>

#include "synthetic_shapes.h"

#include <algorithm>

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

TEST(NanoflannSearch, KNearestAndRadiusMatchBruteForce)
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
    pcl_ecs::NanoflannSearch search;
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

TEST(NanoflannSearch, SortedRadiusResultsAndMaxNeighbours)
{
  auto cloud = gridPlane(20, 0.1);
  pcl_ecs::NanoflannSearch search(true);
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

TEST(NanoflannSearch, SkipsNonFinitePoints)
{
  auto cloud = gridPlane(5, 1.0);
  (*cloud)[3].x = std::numeric_limits<float>::quiet_NaN();
  pcl_ecs::NanoflannSearch search;
  search.setInputCloud(cloud);
  pcl::Indices idx;
  std::vector<float> d2;
  search.nearestKSearch((*cloud)[2], 25, idx, d2);
  EXPECT_EQ(idx.size(), 24u);
  EXPECT_EQ(std::count(idx.begin(), idx.end(), 3), 0);
}
