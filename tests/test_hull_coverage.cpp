#include <pcl_ecs/stages/hull_coverage.h>

#include <gtest/gtest.h>

namespace
{
std::vector<Eigen::Vector2d> grid(int n)
{
  std::vector<Eigen::Vector2d> pts;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      pts.emplace_back(i, j);
  return pts;
}
}  // namespace

TEST(HullCoverage, HullOfAGridIsItsFourCorners)
{
  const auto hull = pcl_ecs::convexHull2D(grid(4));
  ASSERT_EQ(hull.size(), 4u);  // collinear boundary points are not vertices
}

// A 5×5 grid: the 9 interior points are strictly inside; the 16 boundary points are not.
TEST(HullCoverage, BoundaryPointsStayUncovered)
{
  const auto pts = grid(5);
  std::vector<std::uint8_t> inside;
  pcl_ecs::strictlyInsideHull(pts, 1e-9, inside);
  int count = 0;
  for (std::size_t i = 0; i < pts.size(); ++i)
  {
    const bool interior = pts[i].x() > 0 && pts[i].x() < 4 && pts[i].y() > 0 && pts[i].y() < 4;
    EXPECT_EQ(inside[i] != 0, interior) << pts[i].transpose();
    count += inside[i];
  }
  EXPECT_EQ(count, 9);
}

TEST(HullCoverage, DegenerateInputCoversNothing)
{
  std::vector<std::uint8_t> inside;
  pcl_ecs::strictlyInsideHull({{0, 0}, {1, 1}}, 0.0, inside);
  EXPECT_EQ(inside, (std::vector<std::uint8_t>{0, 0}));
  pcl_ecs::strictlyInsideHull({{0, 0}, {1, 1}, {2, 2}, {3, 3}}, 0.0, inside);  // collinear
  EXPECT_EQ(inside, (std::vector<std::uint8_t>(4, 0)));
  EXPECT_TRUE(pcl_ecs::convexHull2D({{0, 0}, {0, 0}, {0, 0}}).empty());
}

// In 3D the offsets are projected onto the tangent plane: a tilted disc of points with the centre
// at the origin, plus a point far above the plane that projects inside: it is covered too.
TEST(HullCoverage, ProjectsOntoTheTangentPlane)
{
  const Eigen::Vector3d n = Eigen::Vector3d(0, 1, 1).normalized();
  const Eigen::Vector3d u = Eigen::Vector3d::UnitX(), v = n.cross(u);
  std::vector<Eigen::Vector3d> offsets = {Eigen::Vector3d::Zero()};
  for (int k = 0; k < 8; ++k)
    offsets.push_back(std::cos(k * M_PI / 4) * u + std::sin(k * M_PI / 4) * v);
  offsets.push_back(0.2 * u + 5.0 * n);
  std::vector<std::uint8_t> inside;
  pcl_ecs::hullCoverage(n, offsets, inside);
  EXPECT_EQ(inside[0], 1);
  for (int k = 1; k <= 8; ++k)
    EXPECT_EQ(inside[static_cast<std::size_t>(k)], 0);
  EXPECT_EQ(inside[9], 1);
}
