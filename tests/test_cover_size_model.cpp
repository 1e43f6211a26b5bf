// The cover-size prediction (stages/cover_size_model.h) on balls whose answer follows from its
// rules by hand: balls below the cap grow like sqrt(s) up to the cap, balls at the cap stay there
// while s·t >= e and shrink below, and the gap points follow the balls at the cap.
#include <pcl_ecs/stages/cover_size_model.h>

#include <vector>

#include <gtest/gtest.h>

namespace
{
using pcl_ecs::CoverBall;
using pcl_ecs::CoverSizeModel;

CoverBall ball(double radius, double error, double tolerance)
{
  CoverBall b;
  b.radius = radius;
  b.error = error;
  b.tolerance = tolerance;
  return b;
}
}  // namespace

TEST(CoverSizeModel, GivesTheCoversOwnCountAtItsOwnTErr)
{
  const double cap = 2.0;
  std::vector<CoverBall> balls = {ball(0.5, 1e-3, 1e-3), ball(2.0, 2e-4, 1e-3), ball(0.0, 0.0, 1e-3),
                                  ball(1.0, 4e-3, 4e-3), ball(2.0, 1e-3, 1e-3)};
  EXPECT_DOUBLE_EQ(CoverSizeModel(balls, cap, 0).count(1.0), 5.0);
  EXPECT_DOUBLE_EQ(CoverSizeModel(balls, cap, 7).count(1.0), 12.0);
}

TEST(CoverSizeModel, ABallBelowTheCapGrowsLikeTheRootOfTheRatioUpToTheCap)
{
  // r = 0.5, cap 2: at s = 4 the radius doubles (a quarter of a ball), at s = 16 it reaches the
  // cap (1/16), and no further at s = 64; at s = 1/4 it halves (four balls).
  const CoverSizeModel m({ball(0.5, 1e-3, 1e-3)}, 2.0, 0);
  EXPECT_DOUBLE_EQ(m.count(4.0), 0.25);
  EXPECT_DOUBLE_EQ(m.count(16.0), 1.0 / 16.0);
  EXPECT_DOUBLE_EQ(m.count(64.0), 1.0 / 16.0);
  EXPECT_DOUBLE_EQ(m.count(0.25), 4.0);
}

TEST(CoverSizeModel, ABallAtTheCapStaysUntilItsErrorExceedsTheScaledToleranceThenShrinks)
{
  // e / t = 0.25: one ball for any s >= 0.25, then e / (s t): two at s = 1/8, four at s = 1/16.
  const CoverSizeModel m({ball(2.0, 0.25e-3, 1e-3)}, 2.0, 0);
  EXPECT_DOUBLE_EQ(m.count(10.0), 1.0);
  EXPECT_DOUBLE_EQ(m.count(0.25), 1.0);
  EXPECT_NEAR(m.count(0.125), 2.0, 1e-6);
  EXPECT_NEAR(m.count(0.0625), 4.0, 1e-6);
  // A ball holding its centre alone stays one ball.
  EXPECT_DOUBLE_EQ(CoverSizeModel({ball(0.0, 0.0, 1e-3)}, 2.0, 0).count(0.01), 1.0);
}

TEST(CoverSizeModel, GapPointsFollowTheBallsAtTheCap)
{
  // Two balls at the cap (e / t = 0.5) and one below it (r = cap / 2, a quarter ball once at the
  // cap, from s = 4 on); 10 gap points with two balls at the cap.
  const std::vector<CoverBall> balls = {ball(2.0, 0.5e-3, 1e-3), ball(2.0, 0.5e-3, 1e-3), ball(1.0, 1e-3, 1e-3)};
  const CoverSizeModel m(balls, 2.0, 10);
  // s = 4: balls 1 + 1 + 1/4; at the cap 2.25 of 2 → 11.25 gap points.
  EXPECT_NEAR(m.count(4.0), 2.25 + 11.25, 1e-6);
  // s = 0.25: the capped balls shrink (e / (s t) = 2 each), none at the cap → no gap points;
  // the small ball: 4.
  EXPECT_NEAR(m.count(0.25), 4.0 + 4.0, 1e-6);
  // Fewer balls for a larger T, never more.
  const CoverSizeModel no_gaps(balls, 2.0, 0);
  for (double s = 1.0 / 32.0; s <= 64.0; s *= 2.0)
    EXPECT_LE(no_gaps.count(s), no_gaps.count(s / 2.0)) << s;
}
