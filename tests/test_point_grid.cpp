// The private point grid (pcl_ecs/src/detail/point_grid.h) against a brute-force search: near,
// nearest and nearestSquared for queries at every radius up to the side, on clustered points (many
// per cell), on coordinates far from the origin and negative ones, and on points whose cells
// share a key (coordinates 2^21 cells apart).
#include "detail/point_grid.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <limits>
#include <random>
#include <vector>

namespace
{
using pcl_ecs::PointGrid;
using V = Eigen::Vector3d;

struct Oracle
{
  std::vector<V> points;
  // The nearest point within r (ties: the lower id), as the grid promises.
  std::int64_t nearest(const V& q, double r, double& d2) const
  {
    std::int64_t best = -1;
    d2 = r * r;
    for (std::size_t i = 0; i < points.size(); ++i)
    {
      const double d = (points[i] - q).squaredNorm();
      if (d <= d2 && (best < 0 || d < d2))
      {
        best = static_cast<std::int64_t>(i);
        d2 = d;
      }
    }
    return best;
  }
};

void expectAgrees(const std::vector<V>& points, const std::vector<V>& queries, double side)
{
  PointGrid grid(side);
  Oracle oracle{points};
  for (std::size_t i = 0; i < points.size(); ++i)
    grid.insert(points[i], static_cast<std::int64_t>(i));
  int hits = 0, misses = 0;
  for (const V& q : queries)
    for (const double f : {0.05, 0.3, 0.5, 0.71, 1.0})
    {
      const double r = f * side;
      double d2 = 0.0;
      const std::int64_t want = oracle.nearest(q, r, d2);
      ASSERT_EQ(grid.nearest(q, r), want) << "query " << q.transpose() << " r " << r;
      ASSERT_EQ(grid.near(q, r), want >= 0);
      const double none = -1.0;
      ASSERT_EQ(grid.nearestSquared(q, r, none), want >= 0 ? d2 : none);
      (want >= 0 ? hits : misses) += 1;
    }
  // Both answers occur, or the comparison says little.
  EXPECT_GT(hits, 50);
  EXPECT_GT(misses, 50);
}

std::vector<V> randomPoints(std::size_t n, const V& lo, const V& hi, unsigned seed)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<V> v(n);
  for (V& p : v)
    p = lo + (hi - lo).cwiseProduct(V(u(rng), u(rng), u(rng)));
  return v;
}

TEST(PointGrid, AgreesWithBruteForceOnUniformPoints)
{
  const std::vector<V> points = randomPoints(3000, V(-1, -1, -1), V(1, 1, 1), 1);
  expectAgrees(points, randomPoints(400, V(-1.2, -1.2, -1.2), V(1.2, 1.2, 1.2), 2), 0.1);
}

TEST(PointGrid, FindsThePointJustWithinTheRadiusInANeighbourCell)
{
  // Sparse points (mostly alone in their 27 cells) and queries just inside a radius the check
  // uses, in every direction: the point found usually lies across a cell face, edge or corner.
  const double side = 0.5;
  const std::vector<V> points = randomPoints(300, V(-5, -5, -5), V(5, 5, 5), 4);
  std::mt19937 rng(5);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<V> queries;
  for (const V& p : points)
    for (const double f : {0.299, 0.709, 0.999})
      queries.push_back(p + f * side * V(g(rng), g(rng), g(rng)).normalized());
  expectAgrees(points, queries, side);
}

TEST(PointGrid, AgreesWithBruteForceOnClusteredPointsFarFromTheOrigin)
{
  // Ten tight clusters (dozens of points per cell; ties between equal points) around 1e5, and
  // repeated points (same position, different ids: the lower id wins).
  std::vector<V> points;
  for (int c = 0; c < 10; ++c)
  {
    const V centre = V(1e5, -2e5, 3e3) + V(c * 0.3, -c * 0.2, c * 0.1);
    for (const V& p : randomPoints(150, centre - V::Constant(0.05), centre + V::Constant(0.05), 10 + c))
      points.push_back(p);
  }
  points.push_back(points[5]);
  points.push_back(points[5]);
  std::vector<V> queries = randomPoints(300, V(1e5 - 0.1, -2e5 - 1.9, 3e3 - 0.1), V(1e5 + 2.8, -2e5 + 0.1, 3e3 + 1.0), 3);
  for (std::size_t i = 0; i < points.size(); i += 37)
    queries.push_back(points[i] + V(0.01, -0.02, 0.015));
  queries.push_back(points[5]);
  expectAgrees(points, queries, 0.04);
}

TEST(PointGrid, CellsThatShareAKeyStillAnswerByDistance)
{
  // x coordinates 2^21 cells apart share a key: a query must not see the other's point.
  const double side = 1.0, wrap = static_cast<double>(1 << 21);
  std::vector<V> points, queries;
  for (int i = 0; i < 200; ++i)
  {
    points.push_back(V(i * 0.7, 0.3 * i, 0.1));
    points.push_back(V(i * 0.7 + wrap, 0.3 * i, 0.1));
    queries.push_back(V(i * 0.7 + 0.2, 0.3 * i - 0.4, 0.5));
    queries.push_back(V(i * 0.7 + wrap + 0.9, 0.3 * i + 0.1, -0.6));
  }
  expectAgrees(points, queries, side);
}

TEST(PointGrid, AnEmptyGridFindsNothing)
{
  const PointGrid grid(0.5);
  EXPECT_FALSE(grid.near(V(0, 0, 0)));
  EXPECT_EQ(grid.nearest(V(1, 2, 3), 0.5), -1);
  EXPECT_EQ(grid.nearestSquared(V(1, 2, 3), 0.5, 7.0), 7.0);
}
}  // namespace
