// One Lloyd step on the representatives, along their fitted surfaces (stages/representative_relax.h):
// against a brute-force oracle of the same step, on shapes with exact answers, and through the filter.
#include <pcl_ecs/feature_aware_cover_simplify.h>
#include <pcl_ecs/stages/gap_fill.h>
#include <pcl_ecs/stages/representative_fit.h>
#include <pcl_ecs/stages/representative_relax.h>

#include "cover_fixture.h"

#include <gtest/gtest.h>

#include <pcl/io/pcd_io.h>
#include <pcl/search/kdtree.h>

#include <limits>

using namespace pcl_ecs_test;

namespace
{
Eigen::Vector3d at(const Cloud& c, std::size_t i) { return c[i].getVector3fMap().cast<double>(); }

struct Step
{
  std::vector<Eigen::Vector3d> reps;
  std::vector<int> sources;
  std::vector<std::size_t> cell;  ///< per point: its nearest output (covered points)
};

/// The step by brute force: every covered point to its nearest output (ties: the lower index), each
/// fitted ball's representative to its cell centroid's tangent position on its quadratic, unless
/// that lies 0.5 r or farther from the centre (or, for a fit made near one point, its support or
/// farther from that point); a moved ball's record from its cell's point nearest to the new
/// position.
Step oracle(const CoverRun& run, const pcl_ecs::CoverOutput& out)
{
  const pcl_ecs::CoverInput in = run.input();
  const std::vector<Eigen::Vector3d> sites = pcl_ecs::outputPositions(in, out);
  const std::size_t features = sites.size() - out.balls.size();
  std::vector<Eigen::Vector3d> sum(out.balls.size(), Eigen::Vector3d::Zero());
  std::vector<int> members(out.balls.size(), 0);
  std::vector<std::size_t> cell(run.cloud_->size(), 0);
  for (std::size_t i = 0; i < run.cloud_->size(); ++i)
  {
    if (out.owner[i] < 0)
      continue;
    std::size_t best = 0;
    for (std::size_t s = 1; s < sites.size(); ++s)
      if ((sites[s] - at(*run.cloud_, i)).squaredNorm() < (sites[best] - at(*run.cloud_, i)).squaredNorm())
        best = s;
    cell[i] = best;
    if (best >= features)
    {
      sum[best - features] += at(*run.cloud_, i);
      ++members[best - features];
    }
  }
  Step step;
  step.cell = cell;
  std::vector<Eigen::Vector3d>& reps = step.reps;
  for (std::size_t b = 0; b < out.balls.size(); ++b)
  {
    const pcl_ecs::CoverBall& ball = out.balls[b];
    reps.push_back(ball.representative);
    step.sources.push_back(ball.attribute_source);
    if (!ball.fitted || members[b] == 0)
      continue;
    const Eigen::Vector3d c = at(*run.cloud_, static_cast<std::size_t>(ball.centre));
    const Eigen::Vector3d n = run.normals[static_cast<std::size_t>(ball.centre)].cast<double>();
    Eigen::Vector3d t = sum[b] / members[b] - c;
    t -= n.dot(t) * n;
    // A fit made near one point (fit_support > 0) is not followed farther than its support.
    if (ball.fit_support > 0.0 && !((t - (ball.fit_at - n.dot(ball.fit_at) * n)).norm() < ball.fit_support))
      continue;
    const Eigen::Vector3d x = pcl_ecs::onFittedHeight(ball.fit, ball.radius, n, t);
    if (!(x.norm() < 0.5 * ball.radius))
      continue;
    reps.back() = c + x;
    double nearest = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < run.cloud_->size(); ++i)
      if (out.owner[i] >= 0 && cell[i] == features + b && (at(*run.cloud_, i) - reps.back()).squaredNorm() < nearest)
      {
        nearest = (at(*run.cloud_, i) - reps.back()).squaredNorm();
        step.sources.back() = static_cast<int>(i);
      }
  }
  return step;
}

/// The ball's record is a point of the oracle's cell nearest to its new position: the oracle's, or
/// one as near (the positions agree to rounding, which may pick the other of two points at one
/// distance).
void expectRecordAsNear(const Cloud& cloud, const pcl_ecs::CoverBall& ball, const Step& expected, std::size_t b)
{
  const auto source = static_cast<std::size_t>(ball.attribute_source);
  const auto theirs = static_cast<std::size_t>(expected.sources[b]);
  EXPECT_EQ(expected.cell[source], expected.cell[theirs]) << b;
  EXPECT_NEAR((at(cloud, source) - ball.representative).norm(), (at(cloud, theirs) - ball.representative).norm(), 1e-9)
      << b;
}

/// Σ over the covered points of the squared distance to the nearest output (the energy a Lloyd step
/// lowers).
double energy(const CoverRun& run, const pcl_ecs::CoverOutput& out)
{
  const std::vector<Eigen::Vector3d> sites = pcl_ecs::outputPositions(run.input(), out);
  double e = 0.0;
  for (std::size_t i = 0; i < run.cloud_->size(); ++i)
    if (out.owner[i] >= 0)
    {
      double best = std::numeric_limits<double>::infinity();
      for (const Eigen::Vector3d& s : sites)
        best = std::min(best, (s - at(*run.cloud_, i)).squaredNorm());
      e += best;
    }
  return e;
}
}  // namespace

// On a plane every fitted representative goes exactly to its cell's centroid, which lies on the
// plane; the sum of squared distances from the points to the output falls.
TEST(RepresentativeRelax, OnAPlaneEachRepresentativeGoesToItsCellCentroid)
{
  auto cloud = randomPlane(3000, 1.0, 5);
  CoverRun run(cloud, pcl_ecs::Parameters{}, 1e-3);
  ASSERT_GT(run.out.balls.size(), 20u);
  pcl_ecs::CoverOutput relaxed = run.out;
  const Step expected = oracle(run, run.out);
  const std::size_t moved = pcl_ecs::relaxRepresentatives(run.input(), 0.5, 2, relaxed);
  std::size_t changed = 0, fitted = 0;
  for (std::size_t b = 0; b < relaxed.balls.size(); ++b)
  {
    EXPECT_LT((relaxed.balls[b].representative - expected.reps[b]).norm(), 1e-9) << b;
    expectRecordAsNear(*cloud, relaxed.balls[b], expected, b);
    EXPECT_NEAR(relaxed.balls[b].representative.z(), 0.0, 1e-6) << b;  // floats on z = 0
    changed += relaxed.balls[b].representative != run.out.balls[b].representative ? 1 : 0;
    fitted += run.out.balls[b].fitted ? 1 : 0;
  }
  EXPECT_EQ(moved, changed);
  EXPECT_GT(fitted, run.out.balls.size() / 2);  // smooth: most balls are fitted
  EXPECT_GT(moved, fitted / 2);
  EXPECT_LT(energy(run, relaxed), 0.95 * energy(run, run.out));
  // Owners and radii stay.
  EXPECT_EQ(relaxed.owner, run.out.owner);
  for (std::size_t b = 0; b < relaxed.balls.size(); ++b)
    EXPECT_EQ(relaxed.balls[b].radius, run.out.balls[b].radius);
}

// On a sphere the moved representatives stay on it (the quadratic fits a cap of radius r to
// within about r⁴ / ρ³) and the step agrees with the oracle.
TEST(RepresentativeRelax, OnASphereRepresentativesStayOnTheSurface)
{
  const double rho = 1.0;
  auto cloud = fibonacciSphere(6000, rho);
  CoverRun run(cloud, pcl_ecs::Parameters{}, 1e-3);
  pcl_ecs::CoverOutput relaxed = run.out;
  const Step expected = oracle(run, run.out);
  const std::size_t moved = pcl_ecs::relaxRepresentatives(run.input(), 0.5, 1, relaxed);
  EXPECT_GT(moved, relaxed.balls.size() / 3);
  for (std::size_t b = 0; b < relaxed.balls.size(); ++b)
  {
    EXPECT_LT((relaxed.balls[b].representative - expected.reps[b]).norm(), 1e-9) << b;
    expectRecordAsNear(*cloud, relaxed.balls[b], expected, b);
    if (relaxed.balls[b].fitted)
    {
      const double r = relaxed.balls[b].radius;
      EXPECT_NEAR(relaxed.balls[b].representative.norm(), rho, 1e-5 + r * r * r * r / (rho * rho * rho)) << b;
    }
  }
  EXPECT_LT(energy(run, relaxed), energy(run, run.out));
}

// Feature points and balls without a fit stay. The feature points are cells of their own, so the
// representatives of the faces' balls move within their faces.
TEST(RepresentativeRelax, FeaturesAndUnfittedBallsStay)
{
  auto cloud = cubeSurface(30, 1.0, 0.0, 3);
  std::vector<std::uint8_t> feature(cloud->size(), 0);
  for (std::size_t i = 0; i < cloud->size(); ++i)
    feature[i] = distanceToCubeEdge(at(*cloud, i), 1.0) < 0.05 ? 1 : 0;
  CoverRun run(cloud, pcl_ecs::Parameters{}, 1e-3, feature);
  pcl_ecs::CoverOutput relaxed = run.out;
  const std::size_t moved = pcl_ecs::relaxRepresentatives(run.input(), 0.5, 2, relaxed);
  EXPECT_GT(moved, 0u);
  const Step expected = oracle(run, run.out);
  std::size_t unfitted = 0;
  for (std::size_t b = 0; b < relaxed.balls.size(); ++b)
  {
    const Eigen::Vector3d v = relaxed.balls[b].representative;
    EXPECT_LT((v - expected.reps[b]).norm(), 1e-9) << b;
    if (!run.out.balls[b].fitted)
    {
      ++unfitted;
      EXPECT_EQ(v, run.out.balls[b].representative);
    }
    else if (v != run.out.balls[b].representative)
      EXPECT_NEAR(v.cwiseAbs().maxCoeff(), 0.5, 1e-6) << b;  // on its face's plane
  }
  // Fewer than 12 points or a crease inside: not fitted (the cube has both near its edges).
  EXPECT_GT(unfitted, 0u);
}

// A fit made near the representative (a large ball's, representative_fit.h: fit_support > 0) holds
// only within its support: a ball whose cell centroid lies farther than that from where the fit was
// made keeps its representative; one whose centroid lies within it moves as any fitted ball.
TEST(RepresentativeRelax, AFitMadeNearOnePointIsNotFollowedPastItsSupport)
{
  auto cloud = randomPlane(3000, 1.0, 5);
  CoverRun run(cloud, pcl_ecs::Parameters{}, 1e-3);
  const Step free_step = oracle(run, run.out);
  // Every fitted ball's fit declared to hold within a support around its representative that
  // reaches halfway to where the free step would move it: none of those move; the same support
  // reaching twice as far lets them all move as before.
  for (const double reach : {0.5, 2.0})
  {
    SCOPED_TRACE(reach);
    pcl_ecs::CoverOutput out = run.out;
    std::size_t declared = 0;
    for (std::size_t b = 0; b < out.balls.size(); ++b)
    {
      pcl_ecs::CoverBall& ball = out.balls[b];
      const double step = (free_step.reps[b] - ball.representative).norm();
      if (!ball.fitted || !(step > 0.0))
        continue;
      ball.fit_at = ball.representative - at(*cloud, static_cast<std::size_t>(ball.centre));
      ball.fit_support = reach * step;
      ++declared;
    }
    ASSERT_GT(declared, 20u);
    const Step expected = oracle(run, out);
    pcl_ecs::CoverOutput relaxed = out;
    const std::size_t moved = pcl_ecs::relaxRepresentatives(run.input(), 0.5, 2, relaxed);
    for (std::size_t b = 0; b < relaxed.balls.size(); ++b)
    {
      EXPECT_LT((relaxed.balls[b].representative - expected.reps[b]).norm(), 1e-9) << b;
      if (out.balls[b].fit_support > 0.0)
        EXPECT_EQ(relaxed.balls[b].representative == out.balls[b].representative, reach < 1.0) << b;
    }
    if (reach < 1.0)
      EXPECT_LT(moved, run.out.balls.size() - declared + 1);
    else
      EXPECT_GE(moved, declared);
  }
}

// The same bytes for any thread count; nothing to do on an empty cover.
TEST(RepresentativeRelax, IndependentOfThreadsAndSafeOnEmpty)
{
  auto cloud = fibonacciSphere(4000, 1.0, 0.01, 9);
  CoverRun run(cloud, pcl_ecs::Parameters{}, 1e-3);
  pcl_ecs::CoverOutput one = run.out, two = run.out, four = run.out;
  pcl_ecs::relaxRepresentatives(run.input(), 0.5, 1, one);
  pcl_ecs::relaxRepresentatives(run.input(), 0.5, 2, two);
  pcl_ecs::relaxRepresentatives(run.input(), 0.5, 4, four);
  for (std::size_t b = 0; b < one.balls.size(); ++b)
  {
    EXPECT_EQ(one.balls[b].representative, two.balls[b].representative);
    EXPECT_EQ(one.balls[b].representative, four.balls[b].representative);
    EXPECT_EQ(one.balls[b].attribute_source, four.balls[b].attribute_source);
  }
  pcl_ecs::CoverOutput empty;
  empty.owner.assign(cloud->size(), -1);
  EXPECT_EQ(pcl_ecs::relaxRepresentatives(run.input(), 0.5, 2, empty), 0u);
  pcl_ecs::Parameters off;
  off.relax_representatives = false;
  pcl_ecs::CoverOutput kept = run.out;
  EXPECT_EQ(pcl_ecs::relaxRepresentatives(run.input(), off, kept), 0u);
  EXPECT_EQ(kept.balls[0].representative, run.out.balls[0].representative);
}

// Through the filter, on a real scan in the T_err mode: the output stands for its points more
// closely (a smaller mean and largest distance from an input point to its nearest output point)
// with the step than without, from the same balls.
TEST(RepresentativeRelax, FilterOutputLiesNearerItsPoints)
{
  auto cloud = std::make_shared<Cloud>();
  ASSERT_EQ(pcl::io::loadPCDFile(sharedData("bunny.pcd"), *cloud), 0);
  struct Coverage
  {
    double mean = 0.0, max = 0.0;
    std::size_t size = 0, balls = 0;
  };
  auto run = [&](bool relax) {
    pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ> f;
    f.setInputCloud(cloud);
    f.setRelaxRepresentatives(relax);
    Cloud out;
    f.filter(out);
    pcl::search::KdTree<pcl::PointXYZ> tree;
    tree.setInputCloud(std::make_shared<Cloud>(out));
    std::vector<int> k(1);
    std::vector<float> d2(1);
    Coverage c;
    for (const auto& p : *cloud)
    {
      tree.nearestKSearch(p, 1, k, d2);
      c.mean += std::sqrt(static_cast<double>(d2[0])) / static_cast<double>(cloud->size());
      c.max = std::max(c.max, std::sqrt(static_cast<double>(d2[0])));
    }
    c.size = out.size();
    c.balls = f.getResult().summary.balls - f.getResult().summary.gap_points;
    return c;
  };
  const Coverage with = run(true), without = run(false);
  EXPECT_EQ(with.balls, without.balls);  // the same cover
  EXPECT_LE(with.size, without.size);     // no more gap points
  EXPECT_LT(with.mean, 0.97 * without.mean);
  EXPECT_LT(with.max, without.max);
}
