// surface_deviation.h: every input point's distance to the output's surface, and the bound that
// adds points until it holds. Exact cases on planes; on curved clouds a brute-force oracle (all
// output points sorted by distance, the plane of the 8 nearest by Eigen's iterative solver).
#include <pcl_ecs/stages/gap_fill.h>
#include <pcl_ecs/stages/surface_deviation.h>

#include "cover_fixture.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <numeric>

using namespace pcl_ecs_test;

namespace
{
/// The deviation of q by brute force.
double bruteDeviation(const std::vector<Eigen::Vector3d>& outputs, const Eigen::Vector3d& q)
{
  std::vector<std::size_t> order(outputs.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return (outputs[a] - q).squaredNorm() < (outputs[b] - q).squaredNorm();
  });
  const double nearest = (outputs[order[0]] - q).norm();
  if (outputs.size() < 3)
    return nearest;
  const std::size_t k = std::min<std::size_t>(8, outputs.size());
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (std::size_t j = 0; j < k; ++j)
    c += outputs[order[j]];
  c /= static_cast<double>(k);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t j = 0; j < k; ++j)
    cov += (outputs[order[j]] - c) * (outputs[order[j]] - c).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  return std::min(nearest, std::abs((q - c).dot(es.eigenvectors().col(0))));
}
}  // namespace

TEST(SurfaceDeviation, OnAPlaneItIsTheHeightAboveItUnlessAnOutputPointIsCloser)
{
  // Outputs on a 10 × 10 grid of spacing 1 in z = 0 (tilted: the plane x + y + z = 0 rotated in).
  std::vector<Eigen::Vector3d> grid;
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j)
      grid.push_back(R * Eigen::Vector3d(i, j, 0));
  const pcl_ecs::OutputSurface surface(grid);
  // Above the middle of a cell, height 0.3: the plane is 0.3 away, the nearest point farther.
  const pcl_ecs::PointDeviation a = surface.at(R * Eigen::Vector3d(4.5, 4.5, 0.3));
  EXPECT_NEAR(a.plane, 0.3, 1e-9);
  EXPECT_NEAR(a.nearest, std::sqrt(0.5 + 0.09), 1e-9);
  EXPECT_NEAR(a.distance(), 0.3, 1e-9);
  // On an output point: 0.
  EXPECT_NEAR(surface.at(grid[33]).distance(), 0.0, 1e-12);
  // Far above the grid: the plane (2.0) is nearer than any point.
  EXPECT_NEAR(surface.at(R * Eigen::Vector3d(5, 5, 2)).distance(), 2.0, 1e-9);
  // Two output points: no plane, the nearest point.
  const pcl_ecs::OutputSurface two({Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0)});
  EXPECT_NEAR(two.at(Eigen::Vector3d(0.2, 0.5, 0)).plane, std::sqrt(0.04 + 0.25), 1e-12);
  // No output point at all: 0, nothing to measure against.
  EXPECT_EQ(pcl_ecs::OutputSurface({}).at(Eigen::Vector3d(1, 2, 3)).distance(), 0.0);
}

TEST(SurfaceDeviation, SummaryGivesMaxRankedP99AndRms)
{
  std::vector<double> d(200);
  for (std::size_t i = 0; i < d.size(); ++i)
    d[i] = static_cast<double>((i * 37) % 200);  // 0..199, shuffled
  const pcl_ecs::DeviationSummary s = pcl_ecs::summarizeDeviations(d);
  EXPECT_EQ(s.max, 199.0);
  EXPECT_EQ(s.p99, 197.0);  // rank ceil(0.99 × 200) − 1 = 197
  double sq = 0.0;
  for (int v = 0; v < 200; ++v)
    sq += static_cast<double>(v) * v;
  EXPECT_NEAR(s.rms, std::sqrt(sq / 200.0), 1e-12);
  EXPECT_EQ(pcl_ecs::summarizeDeviations({}).max, 0.0);
}

TEST(SurfaceDeviation, EveryPointsDeviationMatchesTheBruteForceOracle)
{
  auto cloud = fibonacciSphere(3000, 1.0, 0.002, 3);
  pcl_ecs::Parameters p;
  CoverRun run(cloud, p, 5e-3);
  const pcl_ecs::CoverInput in = run.input();
  const std::vector<double> d = pcl_ecs::coverDeviations(in, run.out, 2);
  const std::vector<Eigen::Vector3d> outputs = pcl_ecs::outputPositions(in, run.out);
  ASSERT_EQ(d.size(), cloud->size());
  double worst = 0.0;
  for (std::size_t i = 0; i < cloud->size(); i += 3)
  {
    EXPECT_NEAR(d[i], bruteDeviation(outputs, (*cloud)[i].getVector3fMap().cast<double>()), 1e-9) << i;
    worst = std::max(worst, d[i]);
  }
  EXPECT_GT(worst, 0.0);
}

TEST(SurfaceDeviation, TheBoundHoldsOnEveryPointAndAddsOnlyPointBalls)
{
  // A noisy sphere, large balls: points farther than half the unbounded maximum become outputs.
  auto cloud = fibonacciSphere(4000, 1.0, 0.01, 7);
  pcl_ecs::Parameters p;
  p.radius_cap_factor = 6.0;
  CoverRun run(cloud, p, 2e-2);
  const pcl_ecs::CoverInput in = run.input();
  const std::vector<double> before = pcl_ecs::coverDeviations(in, run.out, 2);
  const double bound = 0.5 * *std::max_element(before.begin(), before.end());
  const std::size_t balls = run.out.balls.size();
  std::vector<double> after;
  const std::size_t added = pcl_ecs::boundDeviation(in, p, 2e-2, bound, run.out, after);
  EXPECT_GT(added, 0u);
  EXPECT_EQ(run.out.balls.size(), balls + added);
  const std::vector<Eigen::Vector3d> outputs = pcl_ecs::outputPositions(in, run.out);
  for (std::size_t i = 0; i < cloud->size(); ++i)
  {
    EXPECT_LE(after[i], bound) << i;
    if (i % 5 == 0)
      EXPECT_LE(bruteDeviation(outputs, (*cloud)[i].getVector3fMap().cast<double>()), bound) << i;
  }
  for (std::size_t b = balls; b < run.out.balls.size(); ++b)
  {
    EXPECT_EQ(run.out.balls[b].radius, 0.0);
    EXPECT_EQ(run.out.owner[static_cast<std::size_t>(run.out.balls[b].centre)], static_cast<int>(b));
  }
  std::size_t replaced = 0;
  for (const auto& b : run.out.balls)
    replaced += b.replaced;
  EXPECT_EQ(replaced, cloud->size());
  // The same for one thread; no bound adds nothing.
  CoverRun again(cloud, p, 2e-2);
  pcl_ecs::Parameters one = p;
  one.threads = 1;
  std::vector<double> after_one;
  EXPECT_EQ(pcl_ecs::boundDeviation(again.input(), one, 2e-2, bound, again.out, after_one), added);
  EXPECT_EQ(after_one, after);
  EXPECT_EQ(pcl_ecs::boundDeviation(again.input(), p, 2e-2, 0.0, again.out, after_one), 0u);
}
