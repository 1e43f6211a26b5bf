#include <pcl_ecs/stages/adaptive_tolerance.h>

#include <gtest/gtest.h>

using pcl_ecs::adaptTolerance;

TEST(AdaptiveTolerance, TheFourCases)
{
  const double T = 1e-3, f = 3.0, Hm = 1.0, Dm = 0.5;
  EXPECT_DOUBLE_EQ(adaptTolerance(T, true, f, 0.5, Hm, 0.7, Dm), T * f);  // flat and sparse
  EXPECT_DOUBLE_EQ(adaptTolerance(T, true, f, 2.0, Hm, 0.3, Dm), T / f);  // curved and dense
  EXPECT_DOUBLE_EQ(adaptTolerance(T, true, f, 0.5, Hm, 0.3, Dm), T);      // flat but dense
  EXPECT_DOUBLE_EQ(adaptTolerance(T, true, f, 2.0, Hm, 0.7, Dm), T);      // curved but sparse
  EXPECT_DOUBLE_EQ(adaptTolerance(T, true, f, -2.0, Hm, 0.3, Dm), T / f); // sign of H ignored
}

TEST(AdaptiveTolerance, OffOrFactorOneKeepsTheBase)
{
  EXPECT_DOUBLE_EQ(adaptTolerance(1e-3, false, 3.0, 0.1, 1.0, 9.0, 0.5), 1e-3);
  EXPECT_DOUBLE_EQ(adaptTolerance(1e-3, true, 1.0, 0.1, 1.0, 9.0, 0.5), 1e-3);
}
