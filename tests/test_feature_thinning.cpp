// Feature points thinned along the edges (stages/feature_thinning.h, Parameters::feature_spacing).
#include <pcl_ecs/feature_aware_cover_simplify.h>
#include <pcl_ecs/stages/feature_thinning.h>

#include "synthetic_shapes.h"

#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>

using namespace pcl_ecs_test;

// 21 feature points 0.1 apart on a line, all of the same measure, thinned to 0.25: taken in index
// order, every third is kept (0, 0.3, ..., 1.8); each dropped one is stood for by its nearest
// kept one (0.2 by 0.3, not by 0 that dropped it).
TEST(FeatureThinning, ALineKeepsEveryThirdPointAndMapsTheRestToTheNearest)
{
  Cloud line;
  for (int i = 0; i <= 20; ++i)
    line.push_back(toPoint({0.1 * i, 0.0, 0.0}));
  line.push_back(toPoint({5.0, 5.0, 5.0}));  // not a feature point
  std::vector<std::uint8_t> is_feature(line.size(), 1);
  is_feature.back() = 0;
  const std::vector<double> measure(line.size(), 1.0);
  std::vector<std::int64_t> kept_by;
  EXPECT_EQ(pcl_ecs::thinFeatures(line, is_feature, measure, 0.25, kept_by), 7u);
  for (int i = 0; i <= 20; ++i)
  {
    const int nearest_kept = std::min(18, 3 * ((i + 1) / 3));
    EXPECT_EQ(kept_by[static_cast<std::size_t>(i)], nearest_kept) << i;
  }
  EXPECT_EQ(kept_by.back(), -1);
  // Radius 0: every feature point stays.
  EXPECT_EQ(pcl_ecs::thinFeatures(line, is_feature, measure, 0.0, kept_by), 21u);
  for (int i = 0; i <= 20; ++i)
    EXPECT_EQ(kept_by[static_cast<std::size_t>(i)], i);
}

// The sharpest point of a cluster is the one kept, whatever its index.
TEST(FeatureThinning, TheLargestMeasureIsKept)
{
  Cloud pair;
  pair.push_back(toPoint({0.0, 0.0, 0.0}));
  pair.push_back(toPoint({0.05, 0.0, 0.0}));
  const std::vector<std::uint8_t> is_feature = {1, 1};
  std::vector<std::int64_t> kept_by;
  EXPECT_EQ(pcl_ecs::thinFeatures(pair, is_feature, {0.5, 2.0}, 0.1, kept_by), 1u);
  EXPECT_EQ(kept_by[0], 1);
  EXPECT_EQ(kept_by[1], 1);
}

// Through the filter, on the fandisk scan at 1%: the band of feature points along the
// edges is thinned, the size is reached, every thinned-out point's output point is a kept feature
// point within the spacing, and a plain run at feature_spacing thins the same points.
TEST(FeatureThinning, ATargetSizeThinsTheEdgesAndAPlainRunReproducesIt)
{
  auto cloud = std::make_shared<Cloud>();
  ASSERT_EQ(pcl::io::loadPCDFile(sharedData("fandisk_scan.pcd"), *cloud), 0);
  pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ> f;
  f.setInputCloud(cloud);
  const std::size_t target = cloud->size() / 100;
  f.setTargetSize(target);
  Cloud out;
  f.filter(out);
  const auto& r = f.getResult();
  const auto& s = r.summary;
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_TRUE(s.target_reached);
  EXPECT_GT(static_cast<double>(s.thinned_features), 0.4 * static_cast<double>(s.feature_points + s.thinned_features));
  EXPECT_LE(static_cast<double>(s.feature_points), 0.5 * static_cast<double>(target));
  ASSERT_GT(s.feature_spacing, 0.0);
  const double radius = s.feature_spacing * s.neighborhood_radius;
  std::size_t thinned = 0;
  for (std::size_t i = 0; i < cloud->size(); ++i)
  {
    const auto o = static_cast<std::size_t>(r.input_to_output[i]);
    if (r.labels[o] != pcl_ecs::PointLabel::Feature || r.source_index[o] == static_cast<std::int64_t>(i))
      continue;
    ++thinned;
    EXPECT_LE(((*cloud)[i].getVector3fMap() - out[o].getVector3fMap()).norm(), radius * (1 + 1e-6));
  }
  EXPECT_EQ(thinned, s.thinned_features);

  pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ> plain;
  plain.setInputCloud(cloud);
  plain.setErrorThreshold(s.error_threshold);
  plain.setRadiusCapFactor(s.radius_cap_factor);
  plain.setMaxGapFactor(s.max_gap / (s.radius_cap_factor * s.neighborhood_radius));
  plain.setFeatureSpacing(s.feature_spacing);
  Cloud ref;
  plain.filter(ref);
  EXPECT_EQ(plain.getResult().summary.thinned_features, s.thinned_features);
  // The same points, less those a top-up added at the end (fillToCount).
  ASSERT_EQ(ref.size() + s.size_points, out.size());
  for (std::size_t i = 0; i < ref.size(); ++i)
    ASSERT_EQ(ref[i].getVector3fMap(), out[i].getVector3fMap()) << i;
}
