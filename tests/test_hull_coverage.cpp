#include <pcl_ecs/stages/hull_coverage.h>

#include <gtest/gtest.h>

#include <random>

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

// strictlyInsideHull skips the hull for points well inside the polygon of the points extreme in
// eight directions; the answer must be that of the hull test on every point: random clouds
// (discs, thin slivers, duplicates, points on the hull's edges) against the plain test.
TEST(HullCoverage, ShortcutGivesThePlainHullTestsAnswer)
{
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  for (int trial = 0; trial < 300; ++trial)
  {
    const int n = 3 + trial % 60;
    const double squash = trial % 3 == 0 ? 1e-3 : 1.0;  // slivers
    std::vector<Eigen::Vector2d> pts;
    for (int i = 0; i < n; ++i)
      pts.emplace_back(uni(rng), squash * uni(rng));
    if (trial % 4 == 1)
      pts.push_back(pts[0]);  // a duplicate
    if (trial % 5 == 2)
      pts.push_back(0.5 * (pts[1] + pts[2]));  // on a segment (sometimes a hull edge)
    const double eps = trial % 2 ? 0.0 : 1e-9;
    std::vector<std::uint8_t> inside;
    pcl_ecs::strictlyInsideHull(pts, eps, inside);
    // The plain test: every point against every hull edge.
    const std::vector<int> hull = pcl_ecs::convexHull2D(pts);
    for (std::size_t i = 0; i < pts.size(); ++i)
    {
      bool expected = !hull.empty();
      for (std::size_t e = 0; e < hull.size() && expected; ++e)
      {
        const Eigen::Vector2d a = pts[static_cast<std::size_t>(hull[e])];
        const Eigen::Vector2d b = pts[static_cast<std::size_t>(hull[(e + 1) % hull.size()])];
        const Eigen::Vector2d d = (b - a).normalized();
        expected = -d.y() * (pts[i].x() - a.x()) + d.x() * (pts[i].y() - a.y()) > eps;
      }
      EXPECT_EQ(inside[i] != 0, expected) << "trial " << trial << " point " << i;
    }
  }
}
