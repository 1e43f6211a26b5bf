#include <pcl_ecs/stages/radius_solver.h>

#include <pcl_ecs/stages/density_weights.h>

#include "detail/simd.h"  // private: switch the AVX2 loops off and on
#include "synthetic_shapes.h"
#include "test_support.h"

#include <algorithm>
#include <cstring>

#include <gtest/gtest.h>

using namespace pcl_ecs_test;

namespace
{
/// Brute force: every point, sorted by distance to the centre (the oracle for the kd-tree source).
struct AllPoints : pcl_ecs::CandidateSource
{
  AllPoints(const Cloud& cloud, const Eigen::Vector3d& c)
  {
    for (std::size_t i = 0; i < cloud.size(); ++i)
      all.push_back({(cloud[i].getVector3fMap().cast<double>() - c).norm(), static_cast<int>(i)});
    std::sort(all.begin(), all.end());
  }
  bool ensure(double, std::vector<pcl_ecs::BallCandidate>& sorted) override
  {
    const bool changed = sorted.size() != all.size();
    sorted = all;
    return changed;
  }
  std::vector<pcl_ecs::BallCandidate> all;
};

struct Fixture
{
  explicit Fixture(Cloud::Ptr c) : cloud(std::move(c))
  {
    const auto table = makeTable(cloud, 16);
    normals = makeNormals(cloud, table);
    pcl_ecs::computeDensityWeights(*cloud, table, weights);
  }
  pcl_ecs::QuadricSamples samples() const { return {*cloud, normals, weights}; }
  Cloud::Ptr cloud;
  pcl_ecs::NormalList normals;
  std::vector<double> weights;
};
}  // namespace

TEST(RadiusSolver, PlaneReachesTheCapWithZeroError)
{
  Fixture f(gridPlane(41, 0.05));
  const std::size_t c = 20 * 41 + 20;
  const Eigen::Vector3d centre = (*f.cloud)[c].getVector3fMap().cast<double>();
  AllPoints src(*f.cloud, centre);
  std::vector<pcl_ecs::BallCandidate> sorted;
  const auto sol = pcl_ecs::solveRadius(f.samples(), centre, 0.05, 0.4, 0.0, 1e-6, 2.0,
                                        pcl_ecs::ErrorForm::Normalized, src, sorted);
  EXPECT_DOUBLE_EQ(sol.radius, 0.4);
  EXPECT_LT(sol.error, 1e-9);
  EXPECT_LT(sol.x_min.norm(), 1e-9);
}

TEST(RadiusSolver, SphereErrorGrowsWithTheRadiusAndTheSolveIsTight)
{
  Fixture f(fibonacciSphere(20000, 1.0));
  const Eigen::Vector3d centre = (*f.cloud)[1234].getVector3fMap().cast<double>();
  AllPoints src(*f.cloud, centre);
  const double L = 2.0 * std::sqrt(3.0);
  double prev = -1.0;
  for (double r : {0.02, 0.04, 0.08, 0.16, 0.32})
  {
    const auto ev = pcl_ecs::evaluateRadius(f.samples(), centre, src.all, r, L, pcl_ecs::ErrorForm::Normalized);
    EXPECT_GT(ev.error, prev);
    prev = ev.error;
  }
  const double T = 1e-3;
  std::vector<pcl_ecs::BallCandidate> sorted;
  const auto sol = pcl_ecs::solveRadius(f.samples(), centre, 0.01, 1.0, 0.0, T, L,
                                        pcl_ecs::ErrorForm::Normalized, src, sorted);
  ASSERT_GT(sol.radius, 0.01);
  EXPECT_LE(sol.error, T);
  // Tight: a radius 3% larger already exceeds the tolerance (the bisection stops within 2%).
  const auto above = pcl_ecs::evaluateRadius(f.samples(), centre, src.all, sol.radius * 1.03, L,
                                             pcl_ecs::ErrorForm::Normalized);
  EXPECT_GT(above.error, T);
  // The representative of a sphere cap sits within the error of the sphere (relative to L).
  EXPECT_LT(std::abs((centre + sol.x_min).norm() - 1.0), 2.0 * T * L);
  // Starting from a guess finds a radius just as tight.
  const auto guessed = pcl_ecs::solveRadius(f.samples(), centre, 0.01, 1.0, 0.05, T, L,
                                            pcl_ecs::ErrorForm::Normalized, src, sorted);
  EXPECT_LE(guessed.error, T);
  EXPECT_NEAR(guessed.radius, sol.radius, 0.03 * sol.radius);
}

TEST(RadiusSolver, WhenTheFloorFailsTheBallHoldsItsCentreAlone)
{
  Fixture f(fibonacciSphere(2000, 1.0));
  const Eigen::Vector3d centre = (*f.cloud)[10].getVector3fMap().cast<double>();
  AllPoints src(*f.cloud, centre);
  std::vector<pcl_ecs::BallCandidate> sorted;
  const auto sol = pcl_ecs::solveRadius(f.samples(), centre, 0.05, 1.0, 0.0, 1e-12, 3.4,
                                        pcl_ecs::ErrorForm::Normalized, src, sorted);
  EXPECT_EQ(sol.radius, 0.0);
  EXPECT_EQ(sol.error, 0.0);
  EXPECT_EQ(sol.evaluations, 1);
}

// A start far above the root on a noisy surface, where E grows much more slowly than r^2: the
// solve steps down along E's local slope instead of dropping to the floor, and still ends tight.
TEST(RadiusSolver, AStartFarAboveTheRootStepsDownAlongTheSlope)
{
  Cloud::Ptr cloud = fibonacciSphere(20000, 1.0, 0.004, 7);
  Fixture f(cloud);
  const Eigen::Vector3d centre = (*f.cloud)[4321].getVector3fMap().cast<double>();
  AllPoints src(*f.cloud, centre);
  const double L = 2.0 * std::sqrt(3.0);
  const double T = 2e-3;
  std::vector<pcl_ecs::BallCandidate> sorted;
  const auto near = pcl_ecs::solveRadius(f.samples(), centre, 0.005, 1.0, 0.0, T, L,
                                         pcl_ecs::ErrorForm::Normalized, src, sorted);
  ASSERT_GT(near.radius, 0.02);
  int total = 0;
  for (const double factor : {2.0, 3.0, 4.0})
  {
    const auto sol = pcl_ecs::solveRadius(f.samples(), centre, 0.005, 1.0, factor * near.radius, T, L,
                                          pcl_ecs::ErrorForm::Normalized, src, sorted);
    EXPECT_LE(sol.error, T);
    const auto above = pcl_ecs::evaluateRadius(f.samples(), centre, src.all, sol.radius * 1.03, L,
                                               pcl_ecs::ErrorForm::Normalized);
    EXPECT_GT(above.error, T) << "start " << factor << " x the root";
    total += sol.evaluations;
  }
  // Five a solve: start, two or three steps down, the probe that closes the bracket. (Dropping to
  // the floor after the first step down, as the solver once did, took 21 here.)
  EXPECT_LE(total, 15);
}

// The two error forms differ by exactly sqrt(sum of weights).
TEST(RadiusSolver, PaperFormIsNormalizedTimesRootWeightSum)
{
  Fixture f(fibonacciSphere(5000, 1.0));
  const Eigen::Vector3d centre = (*f.cloud)[99].getVector3fMap().cast<double>();
  AllPoints src(*f.cloud, centre);
  const auto n = pcl_ecs::evaluateRadius(f.samples(), centre, src.all, 0.1, 3.0, pcl_ecs::ErrorForm::Normalized);
  const auto p = pcl_ecs::evaluateRadius(f.samples(), centre, src.all, 0.1, 3.0, pcl_ecs::ErrorForm::Paper);
  ASSERT_GT(n.quadric.weight_sum, 0.0);
  EXPECT_NEAR(p.error, n.error * std::sqrt(n.quadric.weight_sum), 1e-12 + 1e-9 * p.error);
}

// The normalized error is scale-free: scaling the cloud scales r and keeps E.
TEST(RadiusSolver, NormalizedErrorIsScaleFree)
{
  const double s = 1000.0;
  Fixture a(fibonacciSphere(5000, 1.0)), b(fibonacciSphere(5000, s));
  const Eigen::Vector3d ca = (*a.cloud)[99].getVector3fMap().cast<double>();
  const Eigen::Vector3d cb = (*b.cloud)[99].getVector3fMap().cast<double>();
  AllPoints sa(*a.cloud, ca), sb(*b.cloud, cb);
  const auto ea = pcl_ecs::evaluateRadius(a.samples(), ca, sa.all, 0.1, 3.0, pcl_ecs::ErrorForm::Normalized);
  const auto eb = pcl_ecs::evaluateRadius(b.samples(), cb, sb.all, 0.1 * s, 3.0 * s, pcl_ecs::ErrorForm::Normalized);
  EXPECT_NEAR(eb.error, ea.error, 1e-4 * ea.error);
}

TEST(RadiusSolver, PortableAndAvx2SumsGiveTheSameBits)
{
  // E(r) ends in a weighted sum that has an AVX2 version (used where the CPU has it) and a
  // portable one: the same operations in the same order, so the same error and point, bit for bit.
  Fixture f(fibonacciSphere(20000, 1.0));
  const Eigen::Vector3d centre = (*f.cloud)[777].getVector3fMap().cast<double>();
  AllPoints src(*f.cloud, centre);
  for (double r : {0.01, 0.03, 0.07, 0.2})
  {
    pcl_ecs::detail::allowAvx2(false);
    const auto portable = pcl_ecs::evaluateRadius(f.samples(), centre, src.all, r, 3.0, pcl_ecs::ErrorForm::Normalized);
    pcl_ecs::detail::allowAvx2(true);
    const auto wide = pcl_ecs::evaluateRadius(f.samples(), centre, src.all, r, 3.0, pcl_ecs::ErrorForm::Normalized);
    EXPECT_GT(portable.quadric.weight_sum, 0.0);
    EXPECT_EQ(portable.error, wide.error) << "r " << r;
    EXPECT_EQ(portable.quadric.weight_sum, wide.quadric.weight_sum) << "r " << r;
    EXPECT_EQ(portable.minimum.x, wide.minimum.x) << "r " << r;
  }
}

TEST(RadiusSolver, CandidatePlanesAreTheSameBitsWithAndWithoutAvx2)
{
  // The planes' terms are computed four candidates at a time where the CPU has AVX2, one at a
  // time elsewhere (and for the last few): the same bits, also when planes are appended to those
  // of a smaller query (first > 0, not a multiple of 4).
  Fixture f(fibonacciSphere(5000, 1.0));
  const Eigen::Vector3d centre = (*f.cloud)[99].getVector3fMap().cast<double>();
  AllPoints src(*f.cloud, centre);
  const std::vector<pcl_ecs::BallCandidate> all(src.all.begin(), src.all.begin() + 203);
  const std::vector<pcl_ecs::BallCandidate> head(all.begin(), all.begin() + 37);
  pcl_ecs::CandidatePlanes portable, wide;
  pcl_ecs::detail::allowAvx2(false);
  pcl_ecs::candidatePlanes(f.samples(), centre, head, portable);
  pcl_ecs::candidatePlanes(f.samples(), centre, all, portable, head.size());
  pcl_ecs::detail::allowAvx2(true);
  pcl_ecs::candidatePlanes(f.samples(), centre, head, wide);
  pcl_ecs::candidatePlanes(f.samples(), centre, all, wide, head.size());
  ASSERT_EQ(portable.size(), all.size());
  ASSERT_EQ(wide.size(), all.size());
  EXPECT_EQ(portable.distance, wide.distance);
  std::size_t differ = 0;
  for (std::size_t i = 0; i < all.size(); ++i)
    differ += std::memcmp(portable.terms[i].t, wide.terms[i].t, sizeof portable.terms[i].t) != 0 ? 1 : 0;
  EXPECT_EQ(differ, 0u);
  // And the terms are those of eq. 13: a n nᵀ, a d n, a d², a (d = n · (p - c)).
  for (const std::size_t i : {std::size_t{0}, std::size_t{41}, std::size_t{202}})
  {
    const auto j = static_cast<std::size_t>(all[i].index);
    const Eigen::Vector3d n = f.normals[j].cast<double>();
    const double a = f.weights[j], d = n.dot((*f.cloud)[j].getVector3fMap().cast<double>() - centre);
    const double* t = wide.terms[i].t;
    EXPECT_NEAR(t[0], a * n.x() * n.x(), 1e-15);
    EXPECT_NEAR(t[4], a * n.y() * n.z(), 1e-15);
    EXPECT_NEAR(t[8], a * n.z() * d, 1e-15);
    EXPECT_NEAR(t[9], a * d * d, 1e-15);
    EXPECT_EQ(t[10], a);
  }
}
