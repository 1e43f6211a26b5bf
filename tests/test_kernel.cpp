#include <pcl_ecs/stages/kernel.h>

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>

using pcl_ecs::kernelG;

TEST(Kernel, ValueAndSlopeContinuousAtHalfSigma)
{
  for (double sigma : {0.01, 1.0, 250.0})
  {
    const double h = 1e-7 * sigma, mid = 0.5 * sigma;
    EXPECT_NEAR(kernelG(mid, sigma), std::exp(-2.0), 1e-15);
    EXPECT_NEAR(kernelG(mid - h, sigma), kernelG(mid + h, sigma), 1e-6);
    const double slope_left = (kernelG(mid, sigma) - kernelG(mid - h, sigma)) / h;
    const double slope_right = (kernelG(mid + h, sigma) - kernelG(mid, sigma)) / h;
    const double analytic = -8.0 * std::exp(-2.0) / sigma;  // d/dρ of either piece at σ/2
    EXPECT_NEAR(slope_left * sigma, analytic * sigma, 1e-5);
    EXPECT_NEAR(slope_right * sigma, analytic * sigma, 1e-5);
  }
}

TEST(Kernel, OneAtZeroZeroBeyondSigmaAndSymmetric)
{
  EXPECT_DOUBLE_EQ(kernelG(0.0, 2.0), 1.0);
  EXPECT_DOUBLE_EQ(kernelG(2.0, 2.0), 0.0);
  EXPECT_DOUBLE_EQ(kernelG(2.0000001, 2.0), 0.0);
  EXPECT_DOUBLE_EQ(kernelG(100.0, 2.0), 0.0);
  EXPECT_DOUBLE_EQ(kernelG(-0.7, 2.0), kernelG(0.7, 2.0));
  EXPECT_DOUBLE_EQ(kernelG(1.5, 2.0), 16.0 * std::exp(-2.0) * std::pow(0.25, 4));
}

TEST(Kernel, DecreasingOnItsSupport)
{
  double prev = kernelG(0.0, 1.0);
  for (int i = 1; i <= 100; ++i)
  {
    const double g = kernelG(i / 100.0, 1.0);
    EXPECT_LT(g, prev);
    prev = g;
  }
}

// The inner piece's exp (a polynomial, so that it vectorises): within 1e-15 of std::exp over the
// whole range it is used on, and exact enough at the ends for the kernel's tests above.
TEST(Kernel, InnerPieceExpMatchesStdExp)
{
  double worst = 0.0;
  for (int i = 0; i <= 20000; ++i)
  {
    const double u = -2.0 * i / 20000.0;
    worst = std::max(worst, std::abs(pcl_ecs::expOnKernelRange(u) / std::exp(u) - 1.0));
  }
  EXPECT_LT(worst, 1e-15);
  EXPECT_DOUBLE_EQ(pcl_ecs::expOnKernelRange(0.0), 1.0);
  EXPECT_DOUBLE_EQ(pcl_ecs::expOnKernelRange(-2.0), std::exp(-2.0));
}
