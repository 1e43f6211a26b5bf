// The representative on the fitted surface (stages/representative_fit.h), on shapes with exact
// answers, and through the cover on a noisy sphere.
#include <pcl_ecs/feature_aware_cover_simplify.h>
#include <pcl_ecs/stages/representative_fit.h>
#include <pcl_ecs/stages/tangent_frame.h>

#include "synthetic_shapes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <random>

using namespace pcl_ecs_test;

namespace
{
/// Members on h(u, v) in the frame of `n` (offsets from the centre), on a jittered grid within r.
struct Ball
{
  std::vector<Eigen::Vector3d> offsets;
  std::vector<double> distances;
};

template <typename Height>
Ball ballOn(const Eigen::Vector3d& n, double r, Height h, int per_side = 9)
{
  Eigen::Vector3d t1, t2;
  pcl_ecs::tangentFrame(n, t1, t2);
  Ball b;
  for (int i = 0; i < per_side; ++i)
    for (int j = 0; j < per_side; ++j)
    {
      const double u = r * (-0.7 + 1.4 * i / (per_side - 1)) + 0.01 * r * ((i * 7 + j * 3) % 5);
      const double v = r * (-0.7 + 1.4 * j / (per_side - 1)) + 0.01 * r * ((i * 5 + j * 11) % 7);
      const Eigen::Vector3d o = u * t1 + v * t2 + h(u, v) * n;
      if (o.norm() > r)
        continue;
      b.offsets.push_back(o);
      b.distances.push_back(o.norm());
    }
  return b;
}
}  // namespace

// Points exactly on a quadratic height field: the fit reproduces it, so the representative lands
// on it at its own tangent position, whatever height it came with.
TEST(RepresentativeFit, LandsExactlyOnAQuadraticSurface)
{
  const Eigen::Vector3d n = Eigen::Vector3d(0.3, -0.4, 0.8).normalized();
  auto h = [](double u, double v) { return 0.02 + 0.1 * u - 0.05 * v + 0.3 * u * u - 0.2 * u * v + 0.5 * v * v; };
  const double r = 0.5;
  const Ball b = ballOn(n, r, h);
  ASSERT_GE(b.offsets.size(), pcl_ecs::kRepresentativeFitMinPoints);
  Eigen::Vector3d t1, t2;
  pcl_ecs::tangentFrame(n, t1, t2);
  for (const auto& [u, v, off] : {std::tuple{0.0, 0.0, 0.05}, std::tuple{0.1, -0.2, -0.03}, std::tuple{-0.25, 0.15, 0.0}})
  {
    const Eigen::Vector3d x = u * t1 + v * t2 + off * n;
    const auto fitted = pcl_ecs::fitRepresentativeHeight(b.offsets, b.distances, r, n, x);
    ASSERT_TRUE(fitted.has_value());
    EXPECT_NEAR(t1.dot(fitted->offset), u, 1e-12);
    EXPECT_NEAR(t2.dot(fitted->offset), v, 1e-12);
    EXPECT_NEAR(n.dot(fitted->offset), h(u, v), 1e-9);
    EXPECT_NEAR(fitted->residual, 0.0, 1e-6);
  }
}

// A plane whose points sit ±e off it in pairs at the same tangent position: the noise cancels and
// the representative lands on the plane, not on the noisy height it came with.
TEST(RepresentativeFit, AveragesSymmetricNoiseAway)
{
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  const double r = 1.0, e = 0.01;
  Ball up = ballOn(n, r, [&](double, double) { return e; });
  const Ball down = ballOn(n, r, [&](double, double) { return -e; });
  up.offsets.insert(up.offsets.end(), down.offsets.begin(), down.offsets.end());
  up.distances.insert(up.distances.end(), down.distances.begin(), down.distances.end());
  const auto fitted = pcl_ecs::fitRepresentativeHeight(up.offsets, up.distances, r, n, {0.1, 0.2, 0.7 * e});
  ASSERT_TRUE(fitted.has_value());
  EXPECT_NEAR(fitted->offset.z(), 0.0, 1e-12);
  EXPECT_NEAR(fitted->residual, e / r, 1e-9);  // every point e off the fit
  EXPECT_NEAR(fitted->offset.x(), 0.1, 1e-15);
  EXPECT_NEAR(fitted->offset.y(), 0.2, 1e-15);
}

TEST(RepresentativeFit, RefusesTooFewOrDegenerateMembersAndFarHeights)
{
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  const Ball b = ballOn(n, 1.0, [](double, double) { return 0.0; });
  // Too few members.
  const std::vector<Eigen::Vector3d> few(b.offsets.begin(), b.offsets.begin() + 11);
  const std::vector<double> few_d(b.distances.begin(), b.distances.begin() + 11);
  EXPECT_FALSE(pcl_ecs::fitRepresentativeHeight(few, few_d, 1.0, n, Eigen::Vector3d::Zero()).has_value());
  // Members on a line: u² and u are not told apart from v-terms.
  std::vector<Eigen::Vector3d> line;
  std::vector<double> line_d;
  for (int i = 0; i < 20; ++i)
  {
    line.emplace_back(-0.9 + 0.09 * i, 0.0, 0.0);
    line_d.push_back(line.back().norm());
  }
  EXPECT_FALSE(pcl_ecs::fitRepresentativeHeight(line, line_d, 1.0, n, Eigen::Vector3d::Zero()).has_value());
  // A fitted height a radius or more off the centre's plane is not believed.
  const Ball steep = ballOn(n, 1.0, [](double u, double) { return 3.0 * u * u; });
  EXPECT_FALSE(pcl_ecs::fitRepresentativeHeight(steep.offsets, steep.distances, 0.2, n, {0.9, 0.0, 0.0}).has_value());
}

// A surface that bends more than a quadratic (a quartic bowl): the quadratic over the whole ball
// misses it at a representative off the centre; the one fitted to the members near it
// (kLocalFitSupport of r around it) lands within a fraction of that. Exact expectations: the points
// lie on h(u, v) = c (u² + v²)² with no noise.
TEST(RepresentativeFit, TheQuadraticNearTheRepresentativeFollowsABendTheBallsQuadraticMisses)
{
  const Eigen::Vector3d n = Eigen::Vector3d(0.2, 0.1, 1.0).normalized();
  const double r = 1.0, c = 0.05;
  auto h = [&](double u, double v) { return c * (u * u + v * v) * (u * u + v * v); };
  const Ball b = ballOn(n, r, h, 41);
  Eigen::Vector3d t1, t2;
  pcl_ecs::tangentFrame(n, t1, t2);
  for (const auto& [u, v] : {std::pair{0.3, 0.0}, std::pair{-0.2, 0.25}, std::pair{0.0, -0.35}})
  {
    SCOPED_TRACE(u);
    const Eigen::Vector3d x = u * t1 + v * t2;
    const auto whole = pcl_ecs::fitRepresentativeHeight(b.offsets, b.distances, r, n, x);
    const auto local = pcl_ecs::fitLocalHeight(b.offsets, r, n, x, pcl_ecs::kLocalFitSupport * r);
    ASSERT_TRUE(whole.has_value());
    ASSERT_TRUE(local.has_value());
    const double whole_miss = std::abs(n.dot(whole->offset) - h(u, v));
    const double local_miss = std::abs(n.dot(local->offset) - h(u, v));
    std::printf("at (%.2f, %.2f): the ball's quadratic misses by %.2e, the local one by %.2e (residuals %.1e, %.1e)\n",
                u, v, whole_miss, local_miss, whole->residual, local->residual);
    EXPECT_GT(whole_miss, 1e-3 * c) << "the shape must bend more than a quadratic over the ball";
    EXPECT_LT(local_miss, 0.45 * whole_miss);  // 0.11-0.39 × here
    EXPECT_LT(local->residual, whole->residual);
    // Same frame: the local coefficients give the same height at x (as relaxRepresentatives reads them).
    EXPECT_NEAR(n.dot(pcl_ecs::onFittedHeight(local->coefficients, r, n, x)), n.dot(local->offset), 1e-12);
    EXPECT_NEAR(t1.dot(local->offset), u, 1e-12);
    EXPECT_NEAR(t2.dot(local->offset), v, 1e-12);
  }
  // On a quadratic surface both fits are exact.
  const Ball q = ballOn(n, r, [](double u, double v) { return 0.1 * u * u - 0.05 * u * v + 0.02 * v; }, 41);
  const auto local = pcl_ecs::fitLocalHeight(q.offsets, r, n, 0.2 * t1, pcl_ecs::kLocalFitSupport * r);
  ASSERT_TRUE(local.has_value());
  EXPECT_NEAR(n.dot(local->offset), 0.1 * 0.04, 1e-9);
}

// The local fit needs kRepresentativeFitMinPoints members within its support of x, not in the ball.
TEST(RepresentativeFit, TheLocalFitNeedsEnoughMembersNearTheRepresentative)
{
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  const Ball b = ballOn(n, 1.0, [](double u, double) { return 0.1 * u * u; });  // 9 × 9 grid, ~0.175 apart
  ASSERT_GE(b.offsets.size(), 40u);
  // Support 0.3 around the centre: about 9 members weigh more than 0.
  EXPECT_FALSE(pcl_ecs::fitLocalHeight(b.offsets, 1.0, n, Eigen::Vector3d::Zero(), 0.3).has_value());
  EXPECT_TRUE(pcl_ecs::fitLocalHeight(b.offsets, 1.0, n, Eigen::Vector3d::Zero(), 0.6).has_value());
  EXPECT_FALSE(pcl_ecs::fitLocalHeight(b.offsets, 1.0, n, Eigen::Vector3d::Zero(), 0.0).has_value());
}

TEST(RepresentativeFit, ASmoothQuadricHasOneDominantDirection)
{
  pcl_ecs::Quadric flat, edge, empty;
  for (int j = 0; j < 10; ++j)
  {
    flat.add(1.0, Eigen::Vector3d::UnitZ(), {0.1 * j, 0.0, 0.0});
    edge.add(1.0, j % 2 ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX(), {0.1 * j, 0.0, 0.0});
  }
  EXPECT_TRUE(pcl_ecs::smoothQuadric(flat, 0.05));
  EXPECT_FALSE(pcl_ecs::smoothQuadric(edge, 0.05));  // two equal directions: a sharp edge inside
  EXPECT_FALSE(pcl_ecs::smoothQuadric(empty, 0.05));
}

// Through the whole method on a noisy sphere: with the fit the representatives lie closer to the
// sphere than the noisy input points do, and closer than without it (where the planes of a convex
// patch meet outside it); so do those of balls wide enough to be held to the noise.
TEST(RepresentativeFit, RepresentativesOfANoisySphereLieOnIt)
{
  const double R = 1.0, sigma = 0.004;
  auto cloud = fibonacciSphere(40000, R);
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, sigma);
  for (auto& p : *cloud)
  {
    const Eigen::Vector3f d = p.getVector3fMap().normalized();
    p.getVector3fMap() += static_cast<float>(noise(rng)) * d;
  }
  auto meanOff = [&](bool fit, std::size_t& balls, double cap = 5.0, double terr = 2e-3) {
    pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ> f;
    f.setInputCloud(cloud);
    f.setErrorThreshold(terr);
    f.setRadiusCapFactor(cap);
    f.setRepresentativeFit(fit);
    Cloud out;
    f.filter(out);
    double sum = 0.0;
    balls = 0;
    for (const auto& b : f.getResult().balls)
      if (!b.used_centre && b.radius > 0.0)
      {
        sum += std::abs(b.representative.norm() - R);
        ++balls;
      }
    return sum / static_cast<double>(balls);
  };
  std::size_t with_n = 0, without_n = 0;
  const double with = meanOff(true, with_n), without = meanOff(false, without_n);
  ASSERT_GT(with_n, 200u);
  ASSERT_GT(without_n, 200u);
  const double input = sigma * std::sqrt(2.0 / M_PI);  // E|N(0, σ)|
  std::printf("mean distance to the sphere: input %.2e, with the fit %.2e (%zu balls), without %.2e (%zu)\n", input,
              with, with_n, without, without_n);
  EXPECT_LT(with, 0.5 * input);
  EXPECT_LT(with, 0.7 * without);
  // Balls past kFitNoiseMinRadius are held to the noise (fitWithinNoise): on this sphere a
  // quadratic fits them as closely as the noise, and they keep their fits, each averaging hundreds
  // of points: within an eighth of the input's distance (with kFitNoiseFactor 1, which refuses
  // some of those fits, 0.14 of it).
  std::size_t wide_n = 0;
  const double wide = meanOff(true, wide_n, 3.0 * pcl_ecs::kFitNoiseMinRadius, 1e-2);
  std::printf("with a cap of %.0f neighbourhood radii: %.2e (%zu balls)\n", 3.0 * pcl_ecs::kFitNoiseMinRadius, wide,
              wide_n);
  ASSERT_GT(wide_n, 50u);
  EXPECT_LT(wide, 0.125 * input);
}

// The residual that admits a ball that is not smooth: a large ball on a sphere of radius 2r (its
// normals spread by ±25°) is fitted within 0.02 r; a ball across a crease (faces at ±30° about
// the tangent plane) is not.
TEST(RepresentativeFit, TheResidualTellsACurvedPatchFromACrease)
{
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  const double r = 1.0, R = 2.0;
  const Ball cap = ballOn(n, r, [&](double u, double v) { return R - std::sqrt(R * R - u * u - v * v); });
  const Ball crease = ballOn(n, r, [](double u, double) { return std::abs(u) * std::tan(M_PI / 6.0); });
  const auto on_cap = pcl_ecs::fitRepresentativeHeight(cap.offsets, cap.distances, r, n, Eigen::Vector3d::Zero());
  const auto on_crease = pcl_ecs::fitRepresentativeHeight(crease.offsets, crease.distances, r, n, Eigen::Vector3d::Zero());
  ASSERT_TRUE(on_cap.has_value());
  ASSERT_TRUE(on_crease.has_value());
  std::printf("residual: cap %.4f, crease %.4f (of r)\n", on_cap->residual, on_crease->residual);
  EXPECT_LT(on_cap->residual, pcl_ecs::kCurvedBallFitResidual);
  EXPECT_GT(on_crease->residual, pcl_ecs::kCurvedBallFitResidual);
}

// The cubic test (kCubicTermsF) on height fields with exact answers: an exact quadratic gives 0 (no
// gain), an exact cubic an infinite statistic; with noise (σ = 0.002 r, seeded) a quadratic stays
// far below the threshold and a cubic of amplitude 0.1 r far above it; too few members give 0.
TEST(RepresentativeFit, TheCubicTestTellsABendTheQuadraticMissesFromNoise)
{
  const Eigen::Vector3d n = Eigen::Vector3d(0.1, -0.3, 1.0).normalized();
  const double r = 1.0, sigma = 0.002;
  auto quadratic = [](double u, double v) { return 0.2 * u * u - 0.1 * u * v + 0.05 * v; };
  auto cubic = [&](double u, double v) { return quadratic(u, v) + 0.1 * u * u * u; };
  auto F = [&](const Ball& b) { return pcl_ecs::cubicTermsF(b.offsets, b.distances, r, n); };
  EXPECT_EQ(F(ballOn(n, r, quadratic, 15)), 0.0);
  EXPECT_EQ(F(ballOn(n, r, cubic, 15)), std::numeric_limits<double>::infinity());
  EXPECT_TRUE(pcl_ecs::bendsBeyondQuadratic(ballOn(n, r, cubic, 15).offsets, ballOn(n, r, cubic, 15).distances, r, n));

  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, sigma);
  auto noisy = [&](auto h) {
    Ball b = ballOn(n, r, h, 15);
    for (auto& o : b.offsets)
      o += noise(rng) * n;
    for (std::size_t j = 0; j < b.offsets.size(); ++j)
      b.distances[j] = b.offsets[j].norm();
    return b;
  };
  double worst_quadratic = 0.0;
  for (int trial = 0; trial < 20; ++trial)
    worst_quadratic = std::max(worst_quadratic, F(noisy(quadratic)));
  const double on_cubic = F(noisy(cubic));
  std::printf("F: the noisy quadratic at most %.2f in 20 draws, the noisy cubic %.1f (threshold %.1f)\n",
              worst_quadratic, on_cubic, pcl_ecs::kCubicTermsF);
  EXPECT_LT(worst_quadratic, 0.6 * pcl_ecs::kCubicTermsF);
  EXPECT_GT(on_cubic, 3.0 * pcl_ecs::kCubicTermsF);

  // Fewer than kCubicTestMinPoints members by weight: no evidence.
  const Ball few = ballOn(n, r, cubic, 5);
  ASSERT_LT(few.offsets.size(), 25u);
  EXPECT_EQ(F(few), 0.0);
}
