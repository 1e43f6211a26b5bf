#include <pcl_ecs/stages/hull_coverage.h>

#include <pcl_ecs/stages/tangent_frame.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace pcl_ecs
{

namespace
{
double cross(const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b)
{
  return (a.x() - o.x()) * (b.y() - o.y()) - (a.y() - o.y()) * (b.x() - o.x());
}

/// Buffers of one thread, kept from call to call (the cover calls this once per ball).
struct HullScratch
{
  std::vector<int> ids, order, hull;
  std::vector<Eigen::Vector3d> lines;
  std::vector<Eigen::Vector2d> projected;
};

HullScratch& hullScratch()
{
  thread_local HullScratch s;
  return s;
}

/// Andrew's monotone chain over points[ids] (ids ascending) into `hull` (indices into points),
/// counter-clockwise without collinear vertices; empty when fewer than 3 vertices remain. Points
/// strictly inside the hull can be left out of ids: the hull is the same.
void hullOf(const std::vector<Eigen::Vector2d>& points, const std::vector<int>& ids, std::vector<int>& order,
            std::vector<int>& hull)
{
  hull.clear();
  const int n = static_cast<int>(ids.size());
  if (n < 3)
    return;
  order.assign(ids.begin(), ids.end());
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    const auto& pa = points[static_cast<std::size_t>(a)];
    const auto& pb = points[static_cast<std::size_t>(b)];
    return pa.x() < pb.x() || (pa.x() == pb.x() && (pa.y() < pb.y() || (pa.y() == pb.y() && a < b)));
  });
  hull.resize(2 * static_cast<std::size_t>(n));
  int k = 0;
  auto P = [&](int i) -> const Eigen::Vector2d& { return points[static_cast<std::size_t>(i)]; };
  for (int i = 0; i < n; ++i)  // lower chain
  {
    while (k >= 2 && cross(P(hull[k - 2]), P(hull[k - 1]), P(order[i])) <= 0.0)
      --k;
    hull[k++] = order[i];
  }
  for (int i = n - 2, t = k + 1; i >= 0; --i)  // upper chain
  {
    while (k >= t && cross(P(hull[k - 2]), P(hull[k - 1]), P(order[i])) <= 0.0)
      --k;
    hull[k++] = order[i];
  }
  hull.resize(static_cast<std::size_t>(std::max(0, k - 1)));
  if (hull.size() < 3)
    hull.clear();
}

/// The edges of the closed polygon points[vertices] (counter-clockwise) as lines (unit normal
/// pointing inwards, offset): the signed distance of p is l.x p.x + l.y p.y + l.z. Edges of zero
/// length are left out.
void edgeLines(const std::vector<Eigen::Vector2d>& points, const int* vertices, std::size_t count,
               std::vector<Eigen::Vector3d>& lines)
{
  lines.clear();
  for (std::size_t e = 0; e < count; ++e)
  {
    const Eigen::Vector2d& a = points[static_cast<std::size_t>(vertices[e])];
    const Eigen::Vector2d& b = points[static_cast<std::size_t>(vertices[(e + 1) % count])];
    const Eigen::Vector2d d = b - a;
    const double len = d.norm();
    if (len <= 0.0)
      continue;
    const Eigen::Vector2d nrm(-d.y() / len, d.x() / len);  // CCW: the left side is inside
    lines.emplace_back(nrm.x(), nrm.y(), -nrm.dot(a));
  }
}

/// True when p lies more than `epsilon` inside every line.
bool insideLines(const std::vector<Eigen::Vector3d>& lines, const Eigen::Vector2d& p, double epsilon)
{
  for (const Eigen::Vector3d& l : lines)
    if (l.x() * p.x() + l.y() * p.y() + l.z() <= epsilon)
      return false;
  return true;
}
}  // namespace

std::vector<int> convexHull2D(const std::vector<Eigen::Vector2d>& points)
{
  std::vector<int> ids(points.size()), order, hull;
  std::iota(ids.begin(), ids.end(), 0);
  hullOf(points, ids, order, hull);
  return hull;
}

void strictlyInsideHull(const std::vector<Eigen::Vector2d>& points, double epsilon,
                        std::vector<std::uint8_t>& inside)
{
  inside.assign(points.size(), 0);
  const int n = static_cast<int>(points.size());
  if (n < 3)
    return;
  HullScratch& s = hullScratch();
  // Akl-Toussaint: the points extreme in eight directions span a polygon inside the hull; a point
  // well inside that polygon (by 2 epsilon and a rounding margin) is well inside the hull, and
  // not a hull vertex, so only the others go through the hull and its test. Same result, less
  // work: most of a ball's members are inside.
  int extreme[8] = {0, 0, 0, 0, 0, 0, 0, 0};  // max x, x+y, y, y-x, then min x, x+y, y, y-x
  auto keys = [&](int i, double* key) {
    const Eigen::Vector2d& p = points[static_cast<std::size_t>(i)];
    key[0] = p.x();
    key[1] = p.x() + p.y();
    key[2] = p.y();
    key[3] = p.y() - p.x();
  };
  double hi[4], lo[4], key[4];
  keys(0, hi);
  keys(0, lo);
  double extent = 0.0;
  for (int i = 0; i < n; ++i)
  {
    keys(i, key);
    for (int dir = 0; dir < 4; ++dir)
    {
      if (key[dir] > hi[dir])
      {
        hi[dir] = key[dir];
        extreme[dir] = i;
      }
      if (key[dir] < lo[dir])
      {
        lo[dir] = key[dir];
        extreme[dir + 4] = i;
      }
    }
    extent = std::max(extent, points[static_cast<std::size_t>(i)].cwiseAbs().maxCoeff());
  }
  // Counter-clockwise by direction: 0°, 45°, 90°, 135° (max), then 180°, ... 315° (the mins).
  edgeLines(points, extreme, 8, s.lines);
  const double margin = 2.0 * epsilon + 1e-12 * extent;
  s.ids.clear();
  for (int i = 0; i < n; ++i)
  {
    if (s.lines.size() >= 3 && insideLines(s.lines, points[static_cast<std::size_t>(i)], margin))
      inside[static_cast<std::size_t>(i)] = 1;
    else
      s.ids.push_back(i);
  }
  hullOf(points, s.ids, s.order, s.hull);
  if (s.hull.empty())
  {
    std::fill(inside.begin(), inside.end(), 0);  // (only when nothing passed the polygon test)
    return;
  }
  edgeLines(points, s.hull.data(), s.hull.size(), s.lines);
  for (const int i : s.ids)
    inside[static_cast<std::size_t>(i)] = insideLines(s.lines, points[static_cast<std::size_t>(i)], epsilon) ? 1 : 0;
}

void hullCoverage(const Eigen::Vector3d& normal, const std::vector<Eigen::Vector3d>& offsets,
                  std::vector<std::uint8_t>& inside)
{
  Eigen::Vector3d u, v;
  tangentFrame(normal, u, v);
  std::vector<Eigen::Vector2d>& projected = hullScratch().projected;
  projected.clear();
  double extent = 0.0;
  for (const Eigen::Vector3d& q : offsets)
  {
    projected.emplace_back(q.dot(u), q.dot(v));
    extent = std::max(extent, projected.back().cwiseAbs().maxCoeff());
  }
  strictlyInsideHull(projected, 1e-9 * extent, inside);
}

}  // namespace pcl_ecs
