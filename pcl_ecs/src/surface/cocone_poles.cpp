// cocone_poles.cpp — step 2 of the Cocone reconstruction (cocone.h): the poles.
#include "cocone_detail.h"

namespace pcl_ecs
{
namespace surface
{
namespace detail
{

namespace
{
/// The index (0-3) of a cell's infinite vertex, or -1 for a finite cell.
int infiniteIndex(const CellArrays& ca, std::uint32_t c)
{
  for (int k = 0; k < 4; ++k)
    if (ca.v[c][k] == kNone)
      return k;
  return -1;
}

/// Every cell's Voronoi vertex: the circumcentre of a finite cell (kind 1), the outward normal of
/// a hull facet, the direction of its Voronoi ray (kind 2); kind 0 for a degenerate cell.
void voronoiVertices(const std::vector<Eigen::Vector3d>& points, const CellArrays& ca,
                     std::vector<Eigen::Vector3d>& cc, std::vector<char>& cell_kind)
{
  const std::uint32_t cell_count = ca.count;
  const auto& cell_v = ca.v;
  const auto& cell_n = ca.n;
  cc.assign(cell_count, Eigen::Vector3d::Zero());
  cell_kind.assign(cell_count, 0);
  const auto cells = static_cast<std::int64_t>(cell_count);
#pragma omp parallel for schedule(static)
  for (std::int64_t ci = 0; ci < cells; ++ci)
  {
    const auto c = static_cast<std::uint32_t>(ci);
    const auto& cv = cell_v[c];
    const int inf = infiniteIndex(ca, c);
    if (inf >= 0)
    {
      // Hull facet: its outward normal is the direction of its Voronoi ray.
      const std::uint32_t va = cv[(inf + 1) & 3], vb = cv[(inf + 2) & 3], vc = cv[(inf + 3) & 3];
      const std::uint32_t nb = cell_n[c][inf];
      std::uint32_t vd = kNone;
      for (std::uint32_t x : cell_v[nb])
        if (x != va && x != vb && x != vc)
          vd = x;
      Eigen::Vector3d nrm = (points[vb] - points[va]).cross(points[vc] - points[va]);
      if (vd != kNone && (points[vd] - points[va]).dot(nrm) > 0)
        nrm = -nrm;
      const double len = nrm.norm();
      if (len > 0)
      {
        cc[c] = nrm / len;
        cell_kind[c] = 2;
      }
      continue;
    }
    Eigen::Vector3d o;
    if (circumcenter(points[cv[0]], points[cv[1]], points[cv[2]], points[cv[3]], o))
    {
      cc[c] = o;
      cell_kind[c] = 1;
    }
  }
}

/// The hull vertices and the sum of their hull facets' outward normals, in a canonical order (by
/// vertex, then facet) so that the sums do not depend on CGAL's storage order.
void hullNormals(const CellArrays& ca, const std::vector<Eigen::Vector3d>& cc, const std::vector<char>& cell_kind,
                 std::vector<Eigen::Vector3d>& hull_normal, std::vector<char>& is_hull)
{
  const std::uint32_t cell_count = ca.count;
  const auto& cell_v = ca.v;
  {
    struct HullPart
    {
      std::uint32_t vertex;
      Triangle facet;
      std::uint32_t cell;
    };
    std::vector<HullPart> parts;
    for (std::uint32_t c = 0; c < cell_count; ++c)
    {
      if (cell_kind[c] != 2)
        continue;
      const int inf = infiniteIndex(ca, c);
      Triangle key = {cell_v[c][(inf + 1) & 3], cell_v[c][(inf + 2) & 3], cell_v[c][(inf + 3) & 3]};
      std::sort(key.begin(), key.end());
      for (std::uint32_t v : key)
        parts.push_back({v, key, c});
    }
    std::sort(parts.begin(), parts.end(), [](const HullPart& x, const HullPart& y) {
      return x.vertex != y.vertex ? x.vertex < y.vertex : x.facet < y.facet;
    });
    for (const HullPart& h : parts)
    {
      hull_normal[h.vertex] += cc[h.cell];
      is_hull[h.vertex] = 1;
    }
  }
}

/// The negative pole's distance h_p of every vertex: the farthest circumcentre on the other side
/// of its axis.
std::vector<double> negativePoleHeights(const std::vector<Eigen::Vector3d>& points, const CellArrays& ca,
                                        const std::vector<Eigen::Vector3d>& cc, const std::vector<char>& cell_kind,
                                        const std::vector<Eigen::Vector3d>& axis)
{
  const std::uint32_t cell_count = ca.count;
  const auto& cell_v = ca.v;
  std::vector<double> height(points.size(), 0.0);
  for (std::uint32_t c = 0; c < cell_count; ++c)
  {
    if (cell_kind[c] != 1)
      continue;
    const Eigen::Vector3d& o = cc[c];
    for (std::uint32_t v : cell_v[c])
    {
      const Eigen::Vector3d d = o - points[v];
      if (d.dot(axis[v]) < 0)
        height[v] = std::max(height[v], d.norm());
    }
  }
  return height;
}
}  // namespace

Poles computePoles(const std::vector<Eigen::Vector3d>& points, const CellArrays& ca, CoconeStats& st)
{
  const std::size_t n = points.size();
  const std::uint32_t cell_count = ca.count;
  const auto& cell_v = ca.v;
  std::vector<Eigen::Vector3d> cc;  // circumcentre, or ray direction
  std::vector<char> cell_kind;      // 0 invalid, 1 finite circumcentre, 2 infinite (ray)
  voronoiVertices(points, ca, cc, cell_kind);
  std::vector<Eigen::Vector3d> hull_normal(n, Eigen::Vector3d::Zero());
  std::vector<char> is_hull(n, 0);
  hullNormals(ca, cc, cell_kind, hull_normal, is_hull);
  // The positive pole: the farthest circumcentre of a vertex's cells (its axis; the hull normal
  // sum on the hull).
  std::vector<Eigen::Vector3d> axis(n, Eigen::Vector3d::Zero());
  std::vector<double> far2(n, -1.0);
  auto lexLess = [](const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
    return x.x() != y.x() ? x.x() < y.x() : (x.y() != y.y() ? x.y() < y.y() : x.z() < y.z());
  };
  for (std::uint32_t c = 0; c < cell_count; ++c)
  {
    if (cell_kind[c] != 1)
      continue;
    const Eigen::Vector3d& o = cc[c];
    for (std::uint32_t v : cell_v[c])
    {
      const double d2 = (o - points[v]).squaredNorm();
      // Ties broken by position, so the pole does not depend on the order of the cells.
      if (d2 > far2[v] || (d2 == far2[v] && lexLess(o, points[v] + axis[v])))
      {
        far2[v] = d2;
        if (!is_hull[v])
          axis[v] = o - points[v];
      }
    }
  }
  std::vector<char> has_axis(n, 0), is_vertex(n, 0);
  for (std::uint32_t c = 0; c < cell_count; ++c)
    for (std::uint32_t v : cell_v[c])
      if (v != kNone)
        is_vertex[v] = 1;
  for (std::uint32_t i = 0; i < n; ++i)
  {
    if (!is_vertex[i])
      continue;
    if (is_hull[i])
    {
      axis[i] = hull_normal[i];
      ++st.hull_vertices;
    }
    const double len = axis[i].norm();
    if (len > 0 && std::isfinite(len))
    {
      axis[i] /= len;
      has_axis[i] = 1;
    }
  }
  std::vector<double> height = negativePoleHeights(points, ca, cc, cell_kind, axis);
  return Poles{std::move(cc), std::move(cell_kind), std::move(is_hull), std::move(is_vertex), std::move(has_axis),
               std::move(axis), std::move(height)};
}


}  // namespace detail
}  // namespace surface
}  // namespace pcl_ecs
