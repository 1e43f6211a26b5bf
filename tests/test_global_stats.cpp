// GlobalStats (stages/global_stats.h): the method's whole-cloud statistics as mergeable sums.
#include <pcl_ecs/stages/global_stats.h>

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

TEST(GlobalStats, TheMeansOfEq4_6_1_12)
{
  // Four points, the last a feature: δ over all four, the means over the three others.
  const std::vector<double> measure{1.0, 2.0, 3.0, 10.0}, spacing{0.5, 1.0, 1.5, 0.0},
      weights{4.0, 9.0, 16.0, 100.0}, curvature{-1.0, 2.0, -3.0, 50.0};
  const std::vector<std::uint8_t> feature{0, 0, 0, 1};
  pcl_ecs::GlobalStats s;
  s.addMeasures(measure);
  s.addNonFeatures(spacing, weights, curvature, feature);
  EXPECT_EQ(s.featureThreshold(2.0), 8.0);           // 2 × 16 / 4
  EXPECT_EQ(s.meanSpacing(), 1.0);                   // (0.5 + 1 + 1.5) / 3
  EXPECT_EQ(s.neighborhoodRadius(), 3.0);            // mean of sqrt(a): (2 + 3 + 4) / 3, not sqrt(mean a)
  EXPECT_EQ(s.meanAbsCurvature(), 2.0);              // (1 + 2 + 3) / 3
  EXPECT_EQ(s.nonfeature_points, 3.0);
  EXPECT_EQ(s.points, 4.0);
}

TEST(GlobalStats, PartsMergeIntoTheWhole)
{
  // Values exact in binary, so any order of addition gives the same sums.
  std::vector<double> measure, spacing, weights, curvature;
  std::vector<std::uint8_t> feature;
  for (int i = 0; i < 64; ++i)
  {
    measure.push_back(0.25 * i);
    spacing.push_back(0.5 * (i % 7));
    weights.push_back(static_cast<double>((i % 5) * (i % 5)));
    curvature.push_back(i % 2 ? -0.125 * i : 0.125 * i);
    feature.push_back(i % 9 == 0 ? 1 : 0);
  }
  pcl_ecs::GlobalStats whole;
  whole.addMeasures(measure);
  whole.addNonFeatures(spacing, weights, curvature, feature);
  // Three tiles of the same points, merged.
  pcl_ecs::GlobalStats merged;
  for (const auto& [first, last] : {std::pair<int, int>{0, 10}, {10, 41}, {41, 64}})
  {
    pcl_ecs::GlobalStats tile;
    for (int i = first; i < last; ++i)
    {
      tile.addMeasure(measure[i]);
      if (!feature[i])
        tile.addNonFeature(spacing[i], weights[i], curvature[i]);
    }
    merged.merge(tile);
  }
  EXPECT_EQ(merged.featureThreshold(6.0), whole.featureThreshold(6.0));
  EXPECT_EQ(merged.meanSpacing(), whole.meanSpacing());
  EXPECT_EQ(merged.neighborhoodRadius(), whole.neighborhoodRadius());
  EXPECT_EQ(merged.meanAbsCurvature(), whole.meanAbsCurvature());
  EXPECT_EQ(merged.points, 64.0);
  EXPECT_EQ(merged.nonfeature_points, 64.0 - 8.0);  // 0, 9, ..., 63 are features
}

TEST(GlobalStats, NoPointsGiveZeroes)
{
  const pcl_ecs::GlobalStats s;
  EXPECT_EQ(s.featureThreshold(6.0), 0.0);
  EXPECT_EQ(s.meanSpacing(), 0.0);
  EXPECT_EQ(s.neighborhoodRadius(), 0.0);
  EXPECT_EQ(s.meanAbsCurvature(), 0.0);
}
