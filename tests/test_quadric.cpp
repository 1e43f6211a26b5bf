#include <pcl_ecs/stages/quadric.h>

#include <gtest/gtest.h>

using pcl_ecs::Quadric;

namespace
{
// Planes are given by a point (offset from the centre) and a normal.
void addPlaneSamples(Quadric& q, const Eigen::Vector3d& point, const Eigen::Vector3d& normal, int count)
{
  for (int i = 0; i < count; ++i)
    q.add(1.0, normal.normalized(), point);
}
}  // namespace

// On a plane the quadric is rank 1: the minimiser is the point of the plane nearest the centre.
TEST(Quadric, PlaneMinimiserIsTheProjectionOfTheCentre)
{
  Quadric q;
  const Eigen::Vector3d n = Eigen::Vector3d(1, -2, 0.5).normalized();
  addPlaneSamples(q, Eigen::Vector3d(0.3, 0.1, -0.2), n, 10);
  const auto m = pcl_ecs::minimizeQuadric(q);
  EXPECT_EQ(m.rank, 1);
  const double dist = n.dot(Eigen::Vector3d(0.3, 0.1, -0.2));  // plane: n·x = dist
  EXPECT_TRUE(m.x.isApprox(dist * n, 1e-12));
  EXPECT_NEAR(m.value, 0.0, 1e-12);
}

// Two planes meeting at an edge: the minimiser is the point of the edge nearest the centre.
TEST(Quadric, EdgeMinimiserIsOnTheEdge)
{
  Quadric q;
  addPlaneSamples(q, Eigen::Vector3d(0.5, 0, 0), Eigen::Vector3d::UnitX(), 5);  // x = 0.5
  addPlaneSamples(q, Eigen::Vector3d(0, 0, -0.25), Eigen::Vector3d::UnitZ(), 3); // z = -0.25
  const auto m = pcl_ecs::minimizeQuadric(q);
  EXPECT_EQ(m.rank, 2);
  EXPECT_TRUE(m.x.isApprox(Eigen::Vector3d(0.5, 0.0, -0.25), 1e-12));
  EXPECT_NEAR(m.value, 0.0, 1e-12);
}

// Three planes: the corner, whatever the weights.
TEST(Quadric, CornerMinimiserIsTheCorner)
{
  Quadric q;
  addPlaneSamples(q, Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(1, 0, 0), 7);
  addPlaneSamples(q, Eigen::Vector3d(0, 2, 0), Eigen::Vector3d(0, 1, 0), 1);
  addPlaneSamples(q, Eigen::Vector3d(0, 0, 3), Eigen::Vector3d(0, 0, -1), 2);
  const auto m = pcl_ecs::minimizeQuadric(q);
  EXPECT_EQ(m.rank, 3);
  EXPECT_TRUE(m.x.isApprox(Eigen::Vector3d(1, 2, 3), 1e-12));
}

// Inconsistent planes (x = 0 and x = 1, equal weights): the minimum is halfway, with Q = 2·0.5².
TEST(Quadric, ValueAtTheMinimum)
{
  Quadric q;
  q.add(1.0, Eigen::Vector3d::UnitX(), Eigen::Vector3d(0, 0, 0));
  q.add(1.0, Eigen::Vector3d::UnitX(), Eigen::Vector3d(1, 0, 0));
  const auto m = pcl_ecs::minimizeQuadric(q);
  EXPECT_NEAR(m.x.x(), 0.5, 1e-12);
  EXPECT_NEAR(m.value, 0.5, 1e-12);
  EXPECT_NEAR(q.evaluate(Eigen::Vector3d(0, 3, 4)), 1.0, 1e-12);  // 0² + 1²
  EXPECT_DOUBLE_EQ(q.weight_sum, 2.0);
}

TEST(Quadric, EmptyQuadricStaysAtTheCentre)
{
  const auto m = pcl_ecs::minimizeQuadric(Quadric{});
  EXPECT_EQ(m.rank, 0);
  EXPECT_EQ(m.x, Eigen::Vector3d::Zero());
  EXPECT_EQ(m.value, 0.0);
}

// A weak second direction (below the cutoff) is truncated instead of amplified.
TEST(Quadric, TinyEigenvaluesAreTruncated)
{
  Quadric q;
  q.add(1.0, Eigen::Vector3d::UnitZ(), Eigen::Vector3d(0, 0, 0.1));
  q.add(1e-6, Eigen::Vector3d::UnitX(), Eigen::Vector3d(1e3, 0, 0));
  const auto m = pcl_ecs::minimizeQuadric(q);
  EXPECT_EQ(m.rank, 1);
  EXPECT_TRUE(m.x.isApprox(Eigen::Vector3d(0, 0, 0.1), 1e-12));
}

// The representative's coarser cutoff (Parameters::representative_cutoff): a direction at 2% of
// the strongest moves the minimiser under the default cutoff (1e-3) and stays at the centre under 5%.
TEST(Quadric, CoarserCutoffHoldsTheWeakDirectionAtTheCentre)
{
  Quadric q;
  q.add(1.0, Eigen::Vector3d::UnitZ(), Eigen::Vector3d(0, 0, 0.3));
  q.add(0.02, Eigen::Vector3d::UnitX(), Eigen::Vector3d(0.5, 0, 0));
  const auto fine = pcl_ecs::minimizeQuadric(q);
  EXPECT_EQ(fine.rank, 2);
  EXPECT_TRUE(fine.x.isApprox(Eigen::Vector3d(0.5, 0, 0.3), 1e-12));
  EXPECT_NEAR(fine.value, 0.0, 1e-15);
  const auto coarse = pcl_ecs::minimizeQuadric(q, 0.05);
  EXPECT_EQ(coarse.rank, 1);
  EXPECT_TRUE(coarse.x.isApprox(Eigen::Vector3d(0, 0, 0.3), 1e-12));
  EXPECT_NEAR(coarse.value, 0.02 * 0.25, 1e-15);  // the x plane's distance, 0.5, squared and weighted
}
