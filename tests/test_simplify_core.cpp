// simplify_core.h: the method's steps in order on a cloud in the local frame (simplifyLocal), what
// it refuses, and the statistics it reports.
#include <pcl_ecs/simplify_core.h>

#include "synthetic_shapes.h"

#include <gtest/gtest.h>

#include <cmath>

using namespace pcl_ecs_test;

TEST(SimplifyCore, RefusesWhatHasNoSurfaceSayingWhy)
{
  pcl_ecs::Parameters params;
  pcl_ecs::CoreOutput out;
  // K + 1 points are needed.
  auto few = std::make_shared<Cloud>();
  for (int i = 0; i < 16; ++i)
    few->push_back(toPoint({i * 1.0, (i % 4) * 1.0, 0.0}));
  EXPECT_EQ(pcl_ecs::simplifyLocal(few, nullptr, params, {}, out), pcl_ecs::Status::TooFewPoints);
  EXPECT_EQ(out.error, "only 16 finite points; the neighbourhood size K = 16 needs at least 17");
  // One spot, one line.
  auto same = std::make_shared<Cloud>();
  auto line = std::make_shared<Cloud>();
  for (int i = 0; i < 40; ++i)
  {
    same->push_back(toPoint({1.0, 2.0, 3.0}));
    line->push_back(toPoint({i * 0.5, i * 1.0, -i * 0.25}));
  }
  EXPECT_EQ(pcl_ecs::simplifyLocal(same, nullptr, params, {}, out), pcl_ecs::Status::Degenerate);
  EXPECT_NE(out.error.find("identical"), std::string::npos);
  EXPECT_EQ(pcl_ecs::simplifyLocal(line, nullptr, params, {}, out), pcl_ecs::Status::Degenerate);
  EXPECT_NE(out.error.find("one line"), std::string::npos);
  // Input normals must match the points, and be usable.
  auto plane = gridPlane(20, 0.1);
  pcl_ecs::NormalList normals(plane->size() - 1, Eigen::Vector3f::UnitZ());
  EXPECT_EQ(pcl_ecs::simplifyLocal(plane, &normals, params, {}, out), pcl_ecs::Status::InvalidArgument);
  normals.assign(plane->size(), Eigen::Vector3f::UnitZ());
  normals[7] = Eigen::Vector3f::Zero();
  EXPECT_EQ(pcl_ecs::simplifyLocal(plane, &normals, params, {}, out), pcl_ecs::Status::BadNormals);
  EXPECT_EQ(out.error, "input normal of point 7 is not finite or has zero length");
}

TEST(SimplifyCore, ReportsTheWholeCloudsStatisticsOfWhatItComputed)
{
  auto sphere = fibonacciSphere(3000, 2.0, 0.002, 5);
  pcl_ecs::Parameters params;
  params.threads = 2;
  pcl_ecs::CoreOutput out;
  ASSERT_EQ(pcl_ecs::simplifyLocal(sphere, nullptr, params, {}, out), pcl_ecs::Status::Ok) << out.error;
  const pcl_ecs::Summary& s = out.summary;
  // δ = α × the mean measure over every point; the means over the non-feature points (eq. 6, the
  // radius unit as the mean of sqrt(a_i), eq. 12 on |H|), summed here independently.
  const std::size_t n = sphere->size();
  double measure = 0, spacing = 0, radius = 0, curvature = 0, nonfeature = 0;
  std::size_t features = 0;
  for (std::size_t i = 0; i < n; ++i)
  {
    measure += out.measure[i];
    if (out.is_feature[i])
    {
      ++features;
      continue;
    }
    spacing += out.density[i];
    radius += std::sqrt(out.weights[i]);
    curvature += std::abs(out.curvature[i]);
    nonfeature += 1.0;
  }
  EXPECT_EQ(s.feature_threshold, params.feature_factor * measure / static_cast<double>(n));
  EXPECT_EQ(s.feature_points, features);
  EXPECT_EQ(s.mean_spacing, spacing / nonfeature);
  EXPECT_EQ(s.neighborhood_radius, radius / nonfeature);
  EXPECT_EQ(s.mean_abs_curvature, curvature / nonfeature);
  EXPECT_NEAR(s.mean_abs_curvature, 0.5, 0.05);  // |H| = 1 / ρ on a sphere of radius 2
  // The cover: every non-feature point owned by a ball, the counts adding up, the T_err mode's
  // one pass.
  for (std::size_t i = 0; i < n; ++i)
    EXPECT_EQ(out.cover.owner[i] >= 0, !out.is_feature[i]) << i;
  EXPECT_EQ(s.balls, out.cover.balls.size());
  EXPECT_EQ(s.output_points, s.feature_points + s.balls);
  EXPECT_EQ(s.error_threshold, params.error_threshold);
  EXPECT_EQ(s.max_gap, params.max_gap_factor * params.radius_cap_factor * s.neighborhood_radius);
  EXPECT_EQ(s.cover_passes, 1);
  EXPECT_LE(s.max_error, params.adaptive_factor * params.error_threshold);
}

TEST(SimplifyCore, TargetSizeSearchReportsItsTrialsAndSettings)
{
  auto sphere = fibonacciSphere(6000, 1.0, 0.001, 9);
  pcl_ecs::Parameters params;
  params.threads = 2;
  params.target_size = 600;
  pcl_ecs::CoreOutput out;
  ASSERT_EQ(pcl_ecs::simplifyLocal(sphere, nullptr, params, {}, out), pcl_ecs::Status::Ok) << out.error;
  const pcl_ecs::Summary& s = out.summary;
  EXPECT_TRUE(s.target_reached);
  EXPECT_LE(std::abs(static_cast<double>(s.output_points) - 600.0), 6.0);
  EXPECT_GE(s.target_iterations, s.cover_passes);
  EXPECT_GE(s.cover_passes, 1);
  // The plain run at the settings the search reports gives the same cover, less the points a
  // top-up added (fillToCount).
  pcl_ecs::Parameters plain = params;
  plain.target_size = 0;
  plain.error_threshold = s.error_threshold;
  plain.radius_cap_factor = s.radius_cap_factor;
  plain.max_gap_factor = s.max_gap / (s.radius_cap_factor * s.neighborhood_radius);
  pcl_ecs::CoreOutput again;
  ASSERT_EQ(pcl_ecs::simplifyLocal(sphere, nullptr, plain, {}, again), pcl_ecs::Status::Ok);
  EXPECT_EQ(again.summary.output_points + s.size_points, s.output_points);
}
