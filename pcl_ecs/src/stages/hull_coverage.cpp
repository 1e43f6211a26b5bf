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
}  // namespace

std::vector<int> convexHull2D(const std::vector<Eigen::Vector2d>& points)
{
  const int n = static_cast<int>(points.size());
  if (n < 3)
    return {};
  std::vector<int> order(static_cast<std::size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    const auto& pa = points[static_cast<std::size_t>(a)];
    const auto& pb = points[static_cast<std::size_t>(b)];
    return pa.x() < pb.x() || (pa.x() == pb.x() && (pa.y() < pb.y() || (pa.y() == pb.y() && a < b)));
  });
  std::vector<int> hull(2 * static_cast<std::size_t>(n));
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
    return {};
  return hull;
}

void strictlyInsideHull(const std::vector<Eigen::Vector2d>& points, double epsilon,
                        std::vector<std::uint8_t>& inside)
{
  inside.assign(points.size(), 0);
  const std::vector<int> hull = convexHull2D(points);
  if (hull.empty())
    return;
  const std::size_t h = hull.size();
  // Edge lines as unit normals pointing inwards: inside when every signed distance > epsilon.
  std::vector<Eigen::Vector3d> lines;
  lines.reserve(h);
  for (std::size_t e = 0; e < h; ++e)
  {
    const Eigen::Vector2d& a = points[static_cast<std::size_t>(hull[e])];
    const Eigen::Vector2d& b = points[static_cast<std::size_t>(hull[(e + 1) % h])];
    const Eigen::Vector2d d = b - a;
    const double len = d.norm();
    if (len <= 0.0)
      continue;
    const Eigen::Vector2d nrm(-d.y() / len, d.x() / len);  // CCW hull: left side is inside
    lines.emplace_back(nrm.x(), nrm.y(), -nrm.dot(a));
  }
  for (std::size_t i = 0; i < points.size(); ++i)
  {
    bool in = true;
    for (const Eigen::Vector3d& l : lines)
      if (l.x() * points[i].x() + l.y() * points[i].y() + l.z() <= epsilon)
      {
        in = false;
        break;
      }
    inside[i] = in ? 1 : 0;
  }
}

void hullCoverage(const Eigen::Vector3d& normal, const std::vector<Eigen::Vector3d>& offsets,
                  std::vector<std::uint8_t>& inside)
{
  Eigen::Vector3d u, v;
  tangentFrame(normal, u, v);
  std::vector<Eigen::Vector2d> projected;
  projected.reserve(offsets.size());
  double extent = 0.0;
  for (const Eigen::Vector3d& q : offsets)
  {
    projected.emplace_back(q.dot(u), q.dot(v));
    extent = std::max(extent, projected.back().cwiseAbs().maxCoeff());
  }
  strictlyInsideHull(projected, 1e-9 * extent, inside);
}

}  // namespace pcl_ecs
