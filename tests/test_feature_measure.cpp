#include <pcl_ecs/stages/feature_measure.h>
#include <pcl_ecs/stages/global_stats.h>

#include "synthetic_shapes.h"
#include "test_support.h"

#include <gtest/gtest.h>

using namespace pcl_ecs_test;

TEST(FeatureMeasure, ZeroOnAPlane)
{
  auto cloud = randomPlane(1000, 1.0, 2);
  const auto table = makeTable(cloud, 16);
  std::vector<double> m;
  pcl_ecs::computeFeatureMeasure(*cloud, makeNormals(cloud, table), table, 2, m);
  for (double v : m)
    EXPECT_LT(v, 1e-7);
}

// A point at the top of a 90° ridge z = -|x| on a grid of spacing h, K = 4: its neighbours at
// (±h, 0, -h) and (0, ±h, 0). The PCA normal of the 5 points is ±z by symmetry, so the measure is
// (h + h + 0 + 0) / 4 = h/2.
TEST(FeatureMeasure, ExactAtARidge)
{
  const double h = 0.1;
  auto cloud = std::make_shared<Cloud>();
  for (int i = -3; i <= 3; ++i)
    for (int j = -3; j <= 3; ++j)
      cloud->push_back(toPoint({i * h, j * h, -std::abs(i) * h}));
  const auto table = makeTable(cloud, 4);
  std::vector<double> m;
  pcl_ecs::computeFeatureMeasure(*cloud, makeNormals(cloud, table), table, 1, m);
  const std::size_t centre = 3 * 7 + 3;
  EXPECT_NEAR(m[centre], h / 2.0, 1e-6);
}

TEST(FeatureMeasure, ThresholdIsAlphaTimesTheMean)
{
  const std::vector<double> m = {1.0, 2.0, 3.0, 10.0};
  pcl_ecs::GlobalStats stats;
  stats.addMeasures(m);
  EXPECT_DOUBLE_EQ(stats.featureThreshold(2.0), 8.0);
  std::vector<std::uint8_t> f;
  EXPECT_EQ(pcl_ecs::classifyFeatures(m, 8.0, f), 1u);
  EXPECT_EQ(f, (std::vector<std::uint8_t>{0, 0, 0, 1}));
  EXPECT_EQ(pcl_ecs::classifyFeatures(m, 3.0, f), 1u);  // strictly greater
  EXPECT_EQ(pcl_ecs::GlobalStats{}.featureThreshold(2.0), 0.0);
}
