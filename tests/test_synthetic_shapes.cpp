// The generators every other test relies on: they must produce what they claim.
#include "synthetic_shapes.h"

#include <gtest/gtest.h>

using namespace pcl_ecs_test;

TEST(SyntheticShapes, GridPlaneHasExactSpacingAndCount)
{
  const auto c = gridPlane(7, 0.5);
  ASSERT_EQ(c->size(), 49u);
  for (const auto& p : *c)
    EXPECT_EQ(p.z, 0.0f);
  EXPECT_FLOAT_EQ((*c)[1].y - (*c)[0].y, 0.5f);
  EXPECT_FLOAT_EQ((*c)[0].x, -1.5f);
}

TEST(SyntheticShapes, FibonacciSphereLiesOnTheSphere)
{
  const auto c = fibonacciSphere(2000, 2.0, 0.0, 1, Eigen::Vector3d(1, 2, 3));
  ASSERT_EQ(c->size(), 2000u);
  for (const auto& p : *c)
    EXPECT_NEAR((p.getVector3fMap().cast<double>() - Eigen::Vector3d(1, 2, 3)).norm(), 2.0, 1e-6);
}

TEST(SyntheticShapes, NoisySphereHasTheAskedNoise)
{
  const auto c = fibonacciSphere(20000, 1.0, 0.01, 7);
  double sum2 = 0.0;
  for (const auto& p : *c)
  {
    const double d = p.getVector3fMap().cast<double>().norm() - 1.0;
    sum2 += d * d;
  }
  EXPECT_NEAR(std::sqrt(sum2 / c->size()), 0.01, 0.0005);  // 20k samples: ~0.5% sampling error
}

TEST(SyntheticShapes, CubeSurfaceCountsAndEdgeDistance)
{
  const int m = 11;
  const auto c = cubeSurface(m, 2.0);
  EXPECT_EQ(c->size(), static_cast<std::size_t>(m * m * m - (m - 2) * (m - 2) * (m - 2)));
  for (const auto& p : *c)
    EXPECT_NEAR(p.getVector3fMap().cwiseAbs().maxCoeff(), 1.0f, 1e-6f);
  EXPECT_DOUBLE_EQ(distanceToCubeEdge({1.0, 0.0, 0.0}, 2.0), 1.0);
  EXPECT_NEAR(distanceToCubeEdge({1.0, 0.9, 0.0}, 2.0), 0.1, 1e-12);
  EXPECT_DOUBLE_EQ(distanceToCubeEdge({1.0, 1.0, 0.3}, 2.0), 0.0);
}

TEST(SyntheticShapes, SeededRngIsReproducible)
{
  Rng a(5), b(5), c(6);
  for (int i = 0; i < 10; ++i)
  {
    const double x = a.uniform();
    EXPECT_EQ(x, b.uniform());
    EXPECT_GE(x, 0.0);
    EXPECT_LT(x, 1.0);
  }
  EXPECT_NE(Rng(5).uniform(), c.uniform());
}

TEST(SyntheticShapes, TorusPointsSatisfyTheImplicitEquation)
{
  const auto c = torus(40, 20, 3.0, 1.0);
  ASSERT_EQ(c->size(), 800u);
  for (const auto& p : *c)
  {
    const double q = std::hypot(p.x, p.y) - 3.0;
    EXPECT_NEAR(q * q + p.z * p.z, 1.0, 1e-5);
  }
}
