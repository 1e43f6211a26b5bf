// gap_fill.h: after the cover, no input point farther than the gap bound from the output.
#include <pcl_ecs/stages/gap_fill.h>
#include <pcl_ecs/stages/feature_thinning.h>

#include "cover_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>

using namespace pcl_ecs_test;

namespace
{
/// The balls from `before` on (those a fill added): each is an input point made an output point of
/// its own, owning that point. Returns the sum of `replaced` over every ball.
std::size_t checkAddedBalls(const Cloud& cloud, const pcl_ecs::CoverOutput& out, std::size_t before)
{
  std::size_t replaced = 0;
  for (std::size_t b = 0; b < out.balls.size(); ++b)
  {
    const auto& ball = out.balls[b];
    replaced += ball.replaced;
    if (b < before)
      continue;
    const auto c = static_cast<std::size_t>(ball.centre);
    EXPECT_EQ(ball.radius, 0.0);
    EXPECT_EQ(ball.replaced, 1u);
    EXPECT_TRUE(ball.used_centre);
    EXPECT_EQ(ball.attribute_source, ball.centre);
    EXPECT_EQ(out.owner[c], static_cast<int>(b));
    EXPECT_EQ(ball.representative, cloud[c].getVector3fMap().cast<double>());
    EXPECT_LE(ball.error, ball.tolerance);
  }
  return replaced;
}

/// Distance from p to the nearest output point (feature points and representatives), brute force.
double distanceToOutput(const Cloud& cloud, const std::vector<std::uint8_t>& feature,
                        const pcl_ecs::CoverOutput& out, const Eigen::Vector3d& p)
{
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (feature[i])
      best = std::min(best, (cloud[i].getVector3fMap().cast<double>() - p).norm());
  for (const auto& b : out.balls)
    best = std::min(best, (b.representative - p).norm());
  return best;
}
}  // namespace

TEST(GapFill, EveryPointEndsWithinTheGapAndTheCountsStayTotal)
{
  // Large balls on a plane (cap 8 neighbourhood radii, a loose T_err): their rims lie far from
  // their representatives. After the fill every point is within the gap of the output.
  auto cloud = randomPlane(4000, 1.0, 5);
  pcl_ecs::Parameters p;
  p.radius_cap_factor = 8.0;
  CoverRun run(cloud, p, 0.2);
  const pcl_ecs::CoverInput in = run.input();
  const double gap = 0.3 * p.radius_cap_factor * in.neighborhood_radius;
  const std::size_t before = run.out.balls.size();
  double worst_before = 0.0;
  for (const auto& q : *cloud)
    worst_before = std::max(worst_before, distanceToOutput(*cloud, run.feature, run.out, q.getVector3fMap().cast<double>()));
  ASSERT_GT(worst_before, gap) << "the test must start with gaps";

  const std::size_t added = pcl_ecs::fillGaps(in, p, 0.2, gap, run.out);
  EXPECT_GT(added, 0u);
  EXPECT_EQ(run.out.balls.size(), before + added);
  for (const auto& q : *cloud)
    EXPECT_LE(distanceToOutput(*cloud, run.feature, run.out, q.getVector3fMap().cast<double>()), gap);
  EXPECT_EQ(checkAddedBalls(*cloud, run.out, before), cloud->size());
  // Greedy in cloud order, but not wasteful: no two added points within the gap of each other.
  for (std::size_t a = before; a < run.out.balls.size(); ++a)
    for (std::size_t b = a + 1; b < run.out.balls.size(); ++b)
      EXPECT_GT((run.out.balls[a].representative - run.out.balls[b].representative).norm(), gap);
}

TEST(GapFill, OpenPointsAreTheFarOnesAndTheTwoStepsAreFillGaps)
{
  // The open points at a bound are exactly the covered points farther than it from every output
  // point (brute force); those of a wider bound, tested only among the open points of a smaller
  // one, are the same; and the greedy step on them adds the balls fillGaps adds.
  auto cloud = randomPlane(3000, 1.0, 9);
  pcl_ecs::Parameters p;
  p.radius_cap_factor = 8.0;
  p.threads = 3;
  CoverRun run(cloud, p, 0.2);
  const pcl_ecs::CoverInput in = run.input();
  const double narrow = 0.2 * p.radius_cap_factor * in.neighborhood_radius;
  const double wide = 1.5 * narrow;
  const std::vector<std::size_t> open_narrow = pcl_ecs::gapOpenPoints(in, p, run.out, narrow);
  const std::vector<std::size_t> open_wide = pcl_ecs::gapOpenPoints(in, p, run.out, wide);
  std::vector<std::size_t> brute;
  for (std::size_t i = 0; i < cloud->size(); ++i)
    if (distanceToOutput(*cloud, run.feature, run.out, (*cloud)[i].getVector3fMap().cast<double>()) > wide)
      brute.push_back(i);
  ASSERT_FALSE(brute.empty()) << "the test must have gaps at the wider bound";
  EXPECT_EQ(open_wide, brute);
  EXPECT_GT(open_narrow.size(), open_wide.size());
  EXPECT_EQ(pcl_ecs::gapOpenPoints(in, p, run.out, wide, &open_narrow), open_wide);
  EXPECT_TRUE(pcl_ecs::gapOpenPoints(in, p, run.out, 0.0).empty());

  pcl_ecs::CoverOutput one_step = run.out, two_steps = run.out;
  const std::size_t added = pcl_ecs::fillGaps(in, p, 0.2, wide, one_step);
  ASSERT_GT(added, 0u);
  EXPECT_EQ(pcl_ecs::fillOpenGaps(in, p, 0.2, wide, open_wide, two_steps), added);
  ASSERT_EQ(two_steps.balls.size(), one_step.balls.size());
  for (std::size_t b = 0; b < one_step.balls.size(); ++b)
    EXPECT_EQ(two_steps.balls[b].centre, one_step.balls[b].centre);
  EXPECT_EQ(two_steps.owner, one_step.owner);
}

TEST(GapFill, OffOrWideGapChangesNothingAndFeaturesCount)
{
  auto cloud = randomPlane(3000, 1.0, 6);
  // The left half are "feature points": output points themselves, never filled around.
  std::vector<std::uint8_t> feature(cloud->size(), 0);
  for (std::size_t i = 0; i < cloud->size(); ++i)
    feature[i] = (*cloud)[i].x < 0.0f ? 1 : 0;
  pcl_ecs::Parameters p;
  p.radius_cap_factor = 8.0;
  CoverRun run(cloud, p, 0.2, feature);
  const pcl_ecs::CoverInput in = run.input();
  const std::size_t before = run.out.balls.size();
  EXPECT_EQ(pcl_ecs::fillGaps(in, p, 0.2, 0.0, run.out), 0u);
  EXPECT_EQ(pcl_ecs::fillGaps(in, p, 0.2, 10.0, run.out), 0u);  // wider than the plane
  EXPECT_EQ(run.out.balls.size(), before);
  const double gap = 0.3 * p.radius_cap_factor * in.neighborhood_radius;
  ASSERT_GT(pcl_ecs::fillGaps(in, p, 0.2, gap, run.out), 0u);
  for (std::size_t b = before; b < run.out.balls.size(); ++b)
  {
    const Eigen::Vector3d c = run.out.balls[b].representative;
    EXPECT_GE(c.x(), 0.0);
    double nearest_feature = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < cloud->size(); ++i)
      if (feature[i])
        nearest_feature = std::min(nearest_feature, ((*cloud)[i].getVector3fMap().cast<double>() - c).norm());
    EXPECT_GT(nearest_feature, gap) << "a point within the gap of a feature point is covered by it";
  }
}

TEST(GapFill, FeaturePointsThinnedOutEndWithinTheGapToo)
{
  // A band of feature points across a plane, thinned to one per 0.3: a dropped one may lie farther
  // than the gap from every output point (its kept one included). The fill makes such points
  // output points of their own, so that every point, covered or thinned out, ends within the gap.
  auto cloud = randomPlane(4000, 1.0, 8);
  std::vector<std::uint8_t> feature(cloud->size(), 0);
  for (std::size_t i = 0; i < cloud->size(); ++i)
    feature[i] = std::abs((*cloud)[i].y) < 0.03f ? 1 : 0;
  pcl_ecs::Parameters p;
  p.radius_cap_factor = 8.0;
  CoverRun run(cloud, p, 0.2, feature);
  std::vector<std::int64_t> kept_by;
  const std::size_t kept = pcl_ecs::thinFeatures(*cloud, run.feature, std::vector<double>(cloud->size(), 1.0), 0.3, kept_by);
  pcl_ecs::CoverInput in = run.input();
  in.feature_kept_by = &kept_by;
  std::vector<std::uint8_t> output_feature(cloud->size(), 0);
  std::size_t thinned = 0;
  for (std::size_t i = 0; i < cloud->size(); ++i)
  {
    output_feature[i] = in.featureOutput(i) ? 1 : 0;
    thinned += feature[i] && !output_feature[i] ? 1 : 0;
  }
  ASSERT_GT(thinned, 10 * kept);
  const double gap = 0.3 * p.radius_cap_factor * in.neighborhood_radius;
  ASSERT_LT(gap, 0.15) << "thinned points must be able to lie beyond the gap";
  auto farthestThinned = [&] {
    double worst = 0.0;
    for (std::size_t i = 0; i < cloud->size(); ++i)
      if (feature[i] && !output_feature[i])
        worst = std::max(worst, distanceToOutput(*cloud, output_feature, run.out, (*cloud)[i].getVector3fMap().cast<double>()));
    return worst;
  };
  ASSERT_GT(farthestThinned(), gap) << "the test must start with a thinned point beyond the gap";
  const std::size_t before = run.out.balls.size();
  pcl_ecs::fillGaps(in, p, 0.2, gap, run.out);
  EXPECT_LE(farthestThinned(), gap);
  for (const auto& q : *cloud)
    EXPECT_LE(distanceToOutput(*cloud, output_feature, run.out, q.getVector3fMap().cast<double>()), gap);
  const std::size_t replaced = checkAddedBalls(*cloud, run.out, before);
  std::size_t on_thinned = 0;
  for (std::size_t b = before; b < run.out.balls.size(); ++b)
    on_thinned += feature[static_cast<std::size_t>(run.out.balls[b].centre)] ? 1 : 0;
  EXPECT_GT(on_thinned, 0u);
  // Every covered point and every thinned point now standing for itself, once.
  std::size_t covered = 0;
  for (std::size_t i = 0; i < cloud->size(); ++i)
    covered += !feature[i] ? 1 : 0;
  EXPECT_EQ(replaced, covered + on_thinned);
}

TEST(GapFill, ThreadCountDoesNotChangeTheResult)
{
  auto cloud = randomPlane(4000, 1.0, 7);
  pcl_ecs::Parameters p;
  p.radius_cap_factor = 8.0;
  std::vector<Eigen::Vector3d> reps[2];
  for (int k = 0; k < 2; ++k)
  {
    p.threads = k == 0 ? 1 : 4;
    CoverRun run(cloud, p, 0.2);
    const pcl_ecs::CoverInput in = run.input();
    pcl_ecs::fillGaps(in, p, 0.2, 0.3 * p.radius_cap_factor * in.neighborhood_radius, run.out);
    for (const auto& b : run.out.balls)
      reps[k].push_back(b.representative);
  }
  EXPECT_EQ(reps[0], reps[1]);
}

TEST(GapFill, FarFromAndCloseGapsOnPlainPoints)
{
  // Outputs on a unit grid; candidates on a finer grid: "far" exactly when beyond the gap of every
  // output (brute force), and the greedy keeps far candidates more than the gap apart, in order.
  std::vector<Eigen::Vector3d> outputs, points;
  for (int i = 0; i <= 4; ++i)
    for (int j = 0; j <= 4; ++j)
      outputs.emplace_back(i, j, 0.0);
  for (int i = 0; i <= 40; ++i)
    for (int j = 0; j <= 40; ++j)
      points.emplace_back(0.1 * i, 0.1 * j, 0.05);
  const double gap = 0.45;
  const auto far = pcl_ecs::farFrom(outputs, points, gap, 3);
  std::size_t far_count = 0;
  for (std::size_t k = 0; k < points.size(); ++k)
  {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& o : outputs)
      best = std::min(best, (o - points[k]).norm());
    EXPECT_EQ(far[k] != 0, best > gap) << k;
    far_count += far[k];
  }
  ASSERT_GT(far_count, 0u);
  EXPECT_EQ(pcl_ecs::farFrom(outputs, points, 0.0, 3), std::vector<std::uint8_t>(points.size(), 0));
  const auto kept = pcl_ecs::closeGaps(outputs, points, gap, 3);
  ASSERT_FALSE(kept.empty());
  EXPECT_TRUE(std::is_sorted(kept.begin(), kept.end()));
  for (std::size_t a = 0; a < kept.size(); ++a)
  {
    EXPECT_TRUE(far[kept[a]]);
    for (std::size_t b = a + 1; b < kept.size(); ++b)
      EXPECT_GT((points[kept[a]] - points[kept[b]]).norm(), gap);
  }
  // Every far point ends within the gap of an output or a kept point.
  for (std::size_t k = 0; k < points.size(); ++k)
  {
    if (!far[k])
      continue;
    double best = std::numeric_limits<double>::infinity();
    for (const std::size_t c : kept)
      best = std::min(best, (points[c] - points[k]).norm());
    EXPECT_LE(best, gap) << k;
  }
}


TEST(GapFill, FillToCountAddsTheFarthestPointEachTime)
{
  // Oracle: the greedy farthest-point insertion by brute force (each step, the covered point
  // farthest from every output point so far; ties to the lower index). Large balls on a plane
  // with half of it feature points, so that both kinds of output count.
  auto cloud = randomPlane(2500, 1.0, 11);
  std::vector<std::uint8_t> feature(cloud->size(), 0);
  for (std::size_t i = 0; i < cloud->size(); ++i)
    feature[i] = (*cloud)[i].x < -0.6f ? 1 : 0;
  pcl_ecs::Parameters p;
  p.radius_cap_factor = 8.0;
  // Runs: 1 and 4 threads measuring every point up front, and measuring only the 4 × count
  // largest bounds up front (the rest in batches as their bounds reach the top of the queue: four
  // batches on this plane); then after a gap bound, told of it (`within`), and told of a bound
  // that does not hold (the points it misses are measured again in the wide grid).
  std::vector<Eigen::Vector3d> reps[5];
  for (int k = 0; k < 5; ++k)
  {
    p.threads = k == 1 ? 4 : 1;
    CoverRun run(cloud, p, 0.2, feature);
    const pcl_ecs::CoverInput in = run.input();
    const double gap = 0.4 * p.radius_cap_factor * in.neighborhood_radius;
    double within = 0.0;
    if (k >= 3)
    {
      ASSERT_GT(pcl_ecs::fillGaps(in, p, 0.2, gap, run.out), 0u);
      within = k == 3 ? gap : 0.2 * gap;
    }
    pcl_ecs::CoverOutput expected = run.out;
    const std::size_t before = run.out.balls.size();
    const std::size_t count = 60;
    ASSERT_EQ(pcl_ecs::fillToCount(in, p, 0.2, count, run.out, within, k == 2 ? 0 : cloud->size()), count);
    ASSERT_EQ(run.out.balls.size(), before + count);
    for (std::size_t step = 0; step < count; ++step)
    {
      double far = -1.0;
      std::size_t pick = 0;
      for (std::size_t i = 0; i < cloud->size(); ++i)
      {
        if (expected.owner[i] < 0)
          continue;
        const double d = distanceToOutput(*cloud, run.feature, expected, (*cloud)[i].getVector3fMap().cast<double>());
        if (d > far)
        {
          far = d;
          pick = i;
        }
      }
      const auto& added = run.out.balls[before + step];
      EXPECT_EQ(static_cast<std::size_t>(added.centre), pick) << "step " << step;
      EXPECT_EQ(added.radius, 0.0);
      EXPECT_EQ(run.out.owner[pick], static_cast<int>(before + step));
      pcl_ecs::addPointBall(in, p, 0.2, pick, expected);
    }
    std::size_t replaced = 0;
    for (const auto& b : run.out.balls)
      replaced += b.replaced;
    std::size_t covered = 0;
    for (const int o : run.out.owner)
      covered += o >= 0 ? 1 : 0;
    EXPECT_EQ(replaced, covered);
    for (const auto& b : run.out.balls)
      reps[k].push_back(b.representative);
    // Asking for more points than there are covered points makes every one of them an output
    // point, then stops.
    EXPECT_LE(pcl_ecs::fillToCount(in, p, 0.2, covered, run.out), covered);
    for (std::size_t i = 0; i < cloud->size(); ++i)
      if (run.out.owner[i] >= 0)
        EXPECT_EQ(run.out.balls[static_cast<std::size_t>(run.out.owner[i])].representative,
                  (*cloud)[i].getVector3fMap().cast<double>()) << "point " << i << " is not an output point";
  }
  EXPECT_EQ(reps[0], reps[1]) << "the thread count changed the result";
  EXPECT_EQ(reps[0], reps[2]) << "measuring fewer points up front changed the result";
  EXPECT_EQ(reps[3], reps[4]) << "the bound the nearest output is looked for within changed the result";
}
