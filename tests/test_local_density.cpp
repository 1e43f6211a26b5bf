#include <pcl_ecs/stages/local_density.h>
#include <pcl_ecs/stages/global_stats.h>

#include "synthetic_shapes.h"
#include "test_support.h"

#include <gtest/gtest.h>

using namespace pcl_ecs_test;

namespace
{
std::vector<double> density(const Cloud::Ptr& cloud, const std::vector<std::uint8_t>& feature, int k)
{
  pcl::search::KdTree<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  std::vector<double> d;
  pcl_ecs::computeLocalDensity(*cloud, makeTable(cloud, k), feature, tree, 2, d);
  return d;
}
/// Eq. 6: the mean spacing over the non-feature points, as the method takes it (GlobalStats).
double meanSpacing(const std::vector<double>& d, const std::vector<std::uint8_t>& feature)
{
  pcl_ecs::GlobalStats stats;
  stats.addNonFeatures(d, std::vector<double>(d.size(), 1.0), std::vector<double>(d.size(), 0.0), feature);
  return stats.meanSpacing();
}
}  // namespace

TEST(LocalDensity, GridSpacing)
{
  auto cloud = gridPlane(10, 0.3);
  const std::vector<std::uint8_t> none(cloud->size(), 0);
  const auto d = density(cloud, none, 8);
  for (double v : d)
    EXPECT_NEAR(v, 0.3, 1e-6);
  EXPECT_NEAR(meanSpacing(d, none), 0.3, 1e-6);
}

// A row of feature points between two rows: the nearest NON-feature point of a row-0 point is
// two rows away, found through the fallback search when K is too small to see past the features.
TEST(LocalDensity, IgnoresFeaturePointsAndFallsBack)
{
  auto cloud = std::make_shared<Cloud>();
  for (int row = 0; row < 3; ++row)
    for (int i = 0; i < 40; ++i)
      cloud->push_back(toPoint({i * 1.0, row * 0.1, 0.0}));
  std::vector<std::uint8_t> feature(cloud->size(), 0);
  for (int i = 0; i < 40; ++i)
    feature[static_cast<std::size_t>(40 + i)] = 1;
  const auto d = density(cloud, feature, 1);  // K = 1 sees only the feature point above
  for (int i = 0; i < 40; ++i)
  {
    EXPECT_NEAR(d[static_cast<std::size_t>(i)], 0.2, 1e-6);
    EXPECT_EQ(d[static_cast<std::size_t>(40 + i)], 0.0);  // features get 0
  }
  EXPECT_NEAR(meanSpacing(d, feature), 0.2, 1e-6);
}
