// The metrics on shapes with exactly known answers.
#include <pcl_ecs/eval/quality_metrics.h>

#include "synthetic_shapes.h"

#include <gtest/gtest.h>

using namespace pcl_ecs_test;
using pcl_ecs::eval::QualityMetrics;

TEST(QualityMetrics, IdenticalCloudsScoreZero)
{
  auto c = randomPlane(3000, 2.0, 9);
  QualityMetrics m;
  ASSERT_TRUE(pcl_ecs::eval::evaluateQuality(*c, *c, nullptr, m));
  EXPECT_LT(m.surface_rms, 1e-7);
  EXPECT_EQ(m.coverage_max, 0.0);
  EXPECT_EQ(m.hausdorff, 0.0);
  EXPECT_NEAR(m.bbox_diagonal, 2.0 * std::sqrt(2.0), 1e-2);
}

// On a curved surface the plane of the 8 nearest points misses a point by about the sagitta of
// the neighbourhood: for a unit sphere sampled with 3,000 points (spacing ≈ 0.065, 8 neighbours
// within ≈ 0.1) that is ≈ 0.1² / 2 / 2 = 0.0025, i.e. about 7e-4 L — small, but not zero.
TEST(QualityMetrics, CurvedSurfaceDeviationIsTheSagitta)
{
  auto c = fibonacciSphere(3000, 1.0);
  QualityMetrics m;
  ASSERT_TRUE(pcl_ecs::eval::evaluateQuality(*c, *c, nullptr, m));
  EXPECT_GT(m.surface_rms, 2e-4);
  EXPECT_LT(m.surface_rms, 2e-3);
  EXPECT_EQ(m.hausdorff, 0.0);
}

// A grid of spacing h and its subset of every other row and column: every original point is on the
// plane of its simplified neighbours (deviation 0), and the worst-covered points are the centres
// of the 2h × 2h cells, at h·√2 from the nearest kept point.
TEST(QualityMetrics, GridAndEveryOtherPoint)
{
  const int n = 41;
  const double h = 0.05;
  auto full = gridPlane(n, h);
  Cloud half;
  for (int i = 0; i < n; i += 2)
    for (int j = 0; j < n; j += 2)
      half.push_back((*full)[static_cast<std::size_t>(i * n + j)]);
  QualityMetrics m;
  ASSERT_TRUE(pcl_ecs::eval::evaluateQuality(*full, half, nullptr, m));
  const double L = std::sqrt(2.0) * (n - 1) * h;
  EXPECT_NEAR(m.bbox_diagonal, L, 1e-6);
  EXPECT_LT(m.surface_rms, 1e-7);
  EXPECT_NEAR(m.coverage_max, h * std::sqrt(2.0) / L, 1e-6);
  EXPECT_NEAR(m.hausdorff, m.coverage_max, 1e-12);
  // Of each 2×2 block: 1 point at 0, 2 at h, 1 at h√2 (boundary rows aside).
  EXPECT_NEAR(m.coverage_mean, (2 * h + h * std::sqrt(2.0)) / 4 / L, 0.05 * h / L);
}

// The grid and a copy of it moved 0.3 h along the plane and d off it: every original point's
// nearest simplified point is its own copy, offset by exactly d along the normal (the in-plane part
// does not count), while the coverage sees the whole move.
TEST(QualityMetrics, TangentOffsetIsTheMoveAlongTheNormalOnly)
{
  const int n = 31;
  const double h = 0.05, d = 0.004;
  auto full = gridPlane(n, h);
  Cloud moved;
  for (const auto& p : *full)
    moved.push_back(toPoint({p.x + 0.3 * h, p.y, p.z + d}));
  QualityMetrics m;
  ASSERT_TRUE(pcl_ecs::eval::evaluateQuality(*full, moved, nullptr, m));
  const double L = m.bbox_diagonal;
  EXPECT_NEAR(m.tangent_rms, d / L, 1e-6 / L);
  EXPECT_NEAR(m.tangent_p99, d / L, 1e-6 / L);
  EXPECT_NEAR(m.coverage_max, std::hypot(0.3 * h, d) / L, 1e-6 / L);
  QualityMetrics same;
  ASSERT_TRUE(pcl_ecs::eval::evaluateQuality(*full, *full, nullptr, same));
  EXPECT_EQ(same.tangent_rms, 0.0);
}

namespace
{
pcl_ecs::eval::TriangleMesh unitCube()
{
  pcl_ecs::eval::TriangleMesh m;
  for (int i = 0; i < 8; ++i)
    m.vertices.emplace_back(i & 1, (i >> 1) & 1, (i >> 2) & 1);
  const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads)
  {
    m.triangles.emplace_back(q[0], q[1], q[2]);
    m.triangles.emplace_back(q[0], q[2], q[3]);
  }
  return m;
}
}  // namespace

TEST(QualityMetrics, SharpEdgesOfACube)
{
  const auto cube = unitCube();
  // 12 edges at 90°, 6 face diagonals at 0°: only the 12 edges are sampled, 10 samples each.
  EXPECT_EQ(pcl_ecs::eval::sampleSharpEdges(cube, 40.0, 0.1).size(), 120u);
  EXPECT_EQ(pcl_ecs::eval::sampleSharpEdges(cube, 95.0, 0.1).size(), 0u);
}

TEST(QualityMetrics, DistanceToTheMeshAndFromItsEdges)
{
  const auto cube = unitCube();
  // The original: the cube's 8 corners and a point inside (to set L = √3). The simplified: points
  // 0.01 above the top face's centre region and the 8 corners.
  Cloud original, simplified;
  for (const auto& v : cube.vertices)
    original.push_back(toPoint(v));
  for (const auto& v : cube.vertices)
    simplified.push_back(toPoint(v));
  simplified.push_back(toPoint({0.5, 0.5, 1.01}));
  QualityMetrics m;
  ASSERT_TRUE(pcl_ecs::eval::evaluateQuality(original, simplified, &cube, m, 40.0, 0.1 / std::sqrt(3.0)));
  const double L = std::sqrt(3.0);
  EXPECT_TRUE(m.has_mesh);
  EXPECT_NEAR(m.mesh_max, 0.01 / L, 1e-6);
  EXPECT_NEAR(m.mesh_mean, 0.01 / L / 9.0, 1e-6);
  EXPECT_NEAR(m.mesh_p99, 0.01 / L, 1e-6);  // 9 points: the 99th percentile is the largest
  EXPECT_EQ(m.sharp_edge_samples, 120u);
  // Edge samples at 0, 0.1, ..., 0.9 along each edge; the nearest corner is at most 0.5 away.
  EXPECT_NEAR(m.edge_p90, 0.4 / L, 1e-6);
}

TEST(QualityMetrics, EmptyInputIsRefused)
{
  Cloud empty;
  QualityMetrics m;
  EXPECT_FALSE(pcl_ecs::eval::evaluateQuality(empty, *gridPlane(5, 1.0), nullptr, m));
  EXPECT_FALSE(pcl_ecs::eval::evaluateQuality(*gridPlane(5, 1.0), empty, nullptr, m));
}
