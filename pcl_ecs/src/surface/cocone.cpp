// cocone.cpp — see cocone.h for the steps.
#include <pcl_ecs/surface/cocone.h>

#include "../radix_sort.h"

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Delaunay_triangulation_cell_base_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Spatial_sort_traits_adapter_3.h>
#include <CGAL/spatial_sort.h>
#include <CGAL/property_map.h>
#include <CGAL/Triangulation_cell_base_with_info_3.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <numeric>
#include <sstream>
#include <unordered_map>
#include <unordered_set>
#include <utility>

namespace pcl_ecs
{
namespace surface
{
namespace
{
using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_3<std::uint32_t, K>;
using CbBase = CGAL::Delaunay_triangulation_cell_base_3<K>;
using Cb = CGAL::Triangulation_cell_base_with_info_3<std::uint32_t, K, CbBase>;
using Tds = CGAL::Triangulation_data_structure_3<Vb, Cb>;
using Delaunay = CGAL::Delaunay_triangulation_3<K, Tds>;

constexpr double kPi = 3.14159265358979323846;
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b)
{
  if (a > b)
    std::swap(a, b);
  return (static_cast<std::uint64_t>(a) << 32) | b;
}

/** Edge → triangles incidence over a fixed triangle array (sorted pairs; deterministic). The edge
 * groups of every triangle are recorded, so the triangles at an edge of a known triangle are found
 * in constant time. The triangle array must outlive the index and stay unchanged. */
class EdgeIndex
{
public:
  using Pair = std::pair<std::uint64_t, std::uint32_t>;
  explicit EdgeIndex(const std::vector<Triangle>& tris) : tris_(&tris)
  {
    pairs_.reserve(tris.size() * 3);
    for (std::uint32_t t = 0; t < tris.size(); ++t)
      for (int k = 0; k < 3; ++k)
        pairs_.emplace_back(edgeKey(tris[t][k], tris[t][(k + 1) % 3]), t);
    // By key, stably: the pairs are made in triangle order, so (key, triangle) order, as a sort
    // of the pairs would give, in a few linear passes.
    radixSortStable(pairs_, [](const Pair& p) { return p.first; });
    tri_group_.assign(tris.size() * 3, 0);
    for (std::uint32_t p = 0; p < pairs_.size(); ++p)
    {
      if (p == 0 || pairs_[p].first != pairs_[p - 1].first)
        start_.push_back(p);
      const auto g = static_cast<std::uint32_t>(start_.size() - 1);
      const Triangle& tri = tris[pairs_[p].second];
      for (int k = 0; k < 3; ++k)
        if (edgeKey(tri[k], tri[(k + 1) % 3]) == pairs_[p].first)
          tri_group_[3 * static_cast<std::size_t>(pairs_[p].second) + k] = g;
    }
    start_.push_back(static_cast<std::uint32_t>(pairs_.size()));
  }
  /** Triangles at edge ab, as a [first, last) range of (key, triangle) pairs (binary search). */
  std::pair<const Pair*, const Pair*> at(std::uint32_t a, std::uint32_t b) const
  {
    const std::uint64_t key = edgeKey(a, b);
    auto lo = std::lower_bound(pairs_.begin(), pairs_.end(), std::make_pair(key, std::uint32_t{0}));
    auto hi = lo;
    while (hi != pairs_.end() && hi->first == key)
      ++hi;
    return {pairs_.data() + (lo - pairs_.begin()), pairs_.data() + (hi - pairs_.begin())};
  }
  /** Triangles at edge ab of triangle t (constant time). */
  std::pair<const Pair*, const Pair*> at(std::uint32_t t, std::uint32_t a, std::uint32_t b) const
  {
    const std::uint64_t key = edgeKey(a, b);
    const Triangle& tri = (*tris_)[t];
    for (int k = 0; k < 3; ++k)
      if (edgeKey(tri[k], tri[(k + 1) % 3]) == key)
      {
        const std::uint32_t g = tri_group_[3 * static_cast<std::size_t>(t) + k];
        return {pairs_.data() + start_[g], pairs_.data() + start_[g + 1]};
      }
    return at(a, b);
  }
  const std::vector<Pair>& pairs() const { return pairs_; }

private:
  const std::vector<Triangle>* tris_;
  std::vector<Pair> pairs_;
  std::vector<std::uint32_t> tri_group_, start_;
};

/** Angle (0, 2π] of the half-plane of triangle (a, b, c) around edge ab, measured from `u` towards
 * `v` (u, v orthonormal, both normal to the edge). */
double halfPlaneAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& e, const Eigen::Vector3d& c,
                      const Eigen::Vector3d& u, const Eigen::Vector3d& v)
{
  Eigen::Vector3d w = c - a;
  w -= w.dot(e) * e;
  double ang = std::atan2(w.dot(v), w.dot(u));
  if (ang <= 0)
    ang += 2 * kPi;
  return ang;
}

/** The vertex of triangle t that is not a or b. */
std::uint32_t apex(const Triangle& t, std::uint32_t a, std::uint32_t b)
{
  for (std::uint32_t x : t)
    if (x != a && x != b)
      return x;
  return t[0];
}

struct UnionFind
{
  std::vector<std::uint32_t> parent;
  explicit UnionFind(std::size_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0u); }
  std::uint32_t find(std::uint32_t x)
  {
    while (parent[x] != x)
      x = parent[x] = parent[parent[x]];
    return x;
  }
  void unite(std::uint32_t a, std::uint32_t b)
  {
    a = find(a);
    b = find(b);
    if (a != b)
      parent[std::max(a, b)] = std::min(a, b);
  }
};

/** Largest angular gap between consecutive triangles around edge ab (2π for a single triangle). */
double largestGap(const std::vector<Eigen::Vector3d>& pts, std::uint32_t a, std::uint32_t b,
                  const std::vector<std::uint32_t>& apexes)
{
  if (apexes.size() < 2)
    return 2 * kPi;
  const Eigen::Vector3d e = (pts[b] - pts[a]).normalized();
  Eigen::Vector3d u = pts[apexes[0]] - pts[a];
  u -= u.dot(e) * e;
  u.normalize();
  const Eigen::Vector3d v = e.cross(u);
  std::vector<double> ang;
  ang.reserve(apexes.size());
  for (std::uint32_t c : apexes)
    ang.push_back(halfPlaneAngle(pts[a], e, pts[c], u, v));
  std::sort(ang.begin(), ang.end());
  double gap = ang.front() + 2 * kPi - ang.back();
  for (std::size_t i = 1; i < ang.size(); ++i)
    gap = std::max(gap, ang[i] - ang[i - 1]);
  return gap;
}

}  // namespace

std::string CoconeParameters::validate() const
{
  std::ostringstream why;
  if (!(cocone_angle > 0 && cocone_angle < kPi / 2))
    why << "cocone angle must be in (0, pi/2) radians, got " << cocone_angle;
  else if (!(boundary_ratio > 0) || !std::isfinite(boundary_ratio))
    why << "boundary ratio must be a positive number, got " << boundary_ratio;
  else if (!(boundary_normal_angle > 0 && boundary_normal_angle < kPi / 2))
    why << "boundary normal angle must be in (0, pi/2) radians, got " << boundary_normal_angle;
  else if (!(max_edge_ratio >= 0) || !std::isfinite(max_edge_ratio))
    why << "max edge ratio must be 0 (off) or positive, got " << max_edge_ratio;
  else if (!(sharp_edge_angle > kPi && sharp_edge_angle <= 2 * kPi))
    why << "sharp edge angle must be in (pi, 2 pi] radians, got " << sharp_edge_angle;
  return why.str();
}

bool circumcenter(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                  const Eigen::Vector3d& d, Eigen::Vector3d& out)
{
  const Eigen::Vector3d ba = b - a, ca = c - a, da = d - a;
  const double den = 2.0 * ba.dot(ca.cross(da));
  if (den == 0.0)
    return false;
  const Eigen::Vector3d num =
      ba.squaredNorm() * ca.cross(da) + ca.squaredNorm() * da.cross(ba) + da.squaredNorm() * ba.cross(ca);
  out = a + num / den;
  return out.allFinite();
}

CoconeHit coconeIntersect(const Eigen::Vector3d& p, const Eigen::Vector3d& axis, double cos_limit,
                          const Eigen::Vector3d& start, const Eigen::Vector3d& end, bool is_ray)
{
  // u(t) = u0 + t w, t in [0, T]; inside the cocone where f(t) = (u·a)^2 − κ^2 |u|^2 ≤ 0.
  const Eigen::Vector3d u0 = start - p;
  const Eigen::Vector3d w = is_ray ? Eigen::Vector3d(end) : Eigen::Vector3d(end - start);
  const double k2 = cos_limit * cos_limit;
  const double A0 = u0.dot(axis), A1 = w.dot(axis);
  const double B0 = u0.squaredNorm(), B1 = u0.dot(w), B2 = w.squaredNorm();
  const double qa = A1 * A1 - k2 * B2, qb = 2 * (A0 * A1 - k2 * B1), qc = A0 * A0 - k2 * B0;
  // Tolerance relative to the magnitudes involved.
  const double scale = B0 + (is_ray ? 0.0 : B2);
  const double tol = 1e-12 * (scale > 0 ? scale : 1.0);
  auto f = [&](double t) { return (qa * t + qb) * t + qc; };
  auto dist = [&](double t) { return (u0 + t * w).norm(); };

  CoconeHit hit;
  double ts[4];  // candidate parameters: ends and roots
  int nts = 0;
  ts[nts++] = 0.0;
  if (!is_ray)
    ts[nts++] = 1.0;
  const double tmax = is_ray ? std::numeric_limits<double>::infinity() : 1.0;
  if (std::abs(qa) > 0)
  {
    const double disc = qb * qb - 4 * qa * qc;
    if (disc >= 0)
    {
      const double sq = std::sqrt(disc);
      const double q = -0.5 * (qb + (qb >= 0 ? sq : -sq));
      if (q != 0)
      {
        ts[nts++] = q / qa;
        ts[nts++] = qc / q;
      }
      else
        ts[nts++] = 0.0;
    }
  }
  else if (qb != 0)
    ts[nts++] = -qc / qb;

  bool any = false;
  double best = 0;
  for (int i = 0; i < nts; ++i)
  {
    const double t = ts[i];
    if (!(t >= 0 && t <= tmax))
      continue;
    if (f(t) <= tol)
    {
      any = true;
      best = std::max(best, dist(t));
    }
  }
  if (is_ray)
  {
    // Behaviour at infinity: inside for good when the direction itself is in the cocone.
    const bool inside_at_infinity = qa < 0 || (qa == 0 && qb < 0);
    if (inside_at_infinity)
    {
      any = true;
      best = std::numeric_limits<double>::infinity();
    }
  }
  // Opposite sides of the plane normal to the axis: the edge crosses that plane, inside the cocone.
  if (!any)
  {
    const double s0 = A0, s1 = is_ray ? A1 : (end - p).dot(axis);
    if ((s0 > 0 && s1 < 0) || (s0 < 0 && s1 > 0))
      any = true;  // (roots above already caught this unless rounding hid them)
  }
  hit.hit = any;
  hit.radius = any ? best : 0.0;
  return hit;
}

MeshTopology analyzeTopology(std::size_t num_points, const std::vector<Triangle>& triangles)
{
  MeshTopology topo;
  topo.triangles = triangles.size();
  std::vector<char> used(num_points, 0);
  std::vector<std::pair<std::uint64_t, int>> dir;
  dir.reserve(triangles.size() * 3);
  for (std::uint32_t t = 0; t < triangles.size(); ++t)
  {
    const Triangle& tri = triangles[t];
    if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2])
    {
      ++topo.degenerate_triangles;
      continue;
    }
    for (int k = 0; k < 3; ++k)
    {
      used[tri[k]] = 1;
      const std::uint32_t a = tri[k], b = tri[(k + 1) % 3];
      dir.emplace_back(edgeKey(a, b), a < b ? +1 : -1);
    }
  }
  topo.used_vertices = static_cast<std::size_t>(std::count(used.begin(), used.end(), 1));
  // By (edge, direction), as a sort of the pairs would give (equal pairs are equal values); the
  // direction fits below the key while the smaller index of an edge stays under 2^31.
  if (num_points <= (std::size_t{1} << 31))
    radixSortStable(dir, [](const std::pair<std::uint64_t, int>& d) {
      return (d.first << 1) | (d.second > 0 ? 1u : 0u);
    });
  else
    std::sort(dir.begin(), dir.end());
  UnionFind loops(num_points);
  std::vector<char> on_boundary(num_points, 0);
  for (std::size_t i = 0; i < dir.size();)
  {
    std::size_t j = i;
    int sum = 0;
    while (j < dir.size() && dir[j].first == dir[i].first)
      sum += dir[j++].second;
    const std::size_t n = j - i;
    ++topo.edges;
    if (n == 1)
    {
      ++topo.boundary_edges;
      const auto a = static_cast<std::uint32_t>(dir[i].first >> 32);
      const auto b = static_cast<std::uint32_t>(dir[i].first & 0xffffffffu);
      loops.unite(a, b);
      on_boundary[a] = on_boundary[b] = 1;
    }
    else if (n > 2)
      ++topo.nonmanifold_edges;
    else if (sum != 0)
      topo.consistently_oriented = false;
    i = j;
  }
  for (std::size_t v = 0; v < num_points; ++v)
    if (on_boundary[v] && loops.find(static_cast<std::uint32_t>(v)) == v)
      ++topo.boundary_loops;
  topo.euler_characteristic = static_cast<long>(topo.used_vertices) - static_cast<long>(topo.edges) +
                              static_cast<long>(topo.triangles - topo.degenerate_triangles);

  // Vertex stars: the triangles around v must form one fan (connected through edges at v).
  std::vector<std::uint32_t> offset(num_points + 1, 0);
  for (const Triangle& tri : triangles)
    for (std::uint32_t x : tri)
      ++offset[x + 1];
  for (std::size_t v = 0; v < num_points; ++v)
    offset[v + 1] += offset[v];
  std::vector<std::uint32_t> star(offset.back());
  std::vector<std::uint32_t> fill(offset.begin(), offset.end() - 1);
  for (std::uint32_t t = 0; t < triangles.size(); ++t)
    for (std::uint32_t x : triangles[t])
      star[fill[x]++] = t;
  for (std::size_t v = 0; v < num_points; ++v)
  {
    const std::uint32_t s = offset[v], e = offset[v + 1];
    if (e - s <= 1)
      continue;
    // Link edges: each triangle (v, x, y) joins x and y; the star is a disk or half-disk when the
    // link is a single path or cycle.
    std::unordered_map<std::uint32_t, std::uint32_t> id;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> links;
    for (std::uint32_t k = s; k < e; ++k)
    {
      const Triangle& tri = triangles[star[k]];
      std::uint32_t o[2], n = 0;
      for (std::uint32_t x : tri)
        if (x != v && n < 2)
          o[n++] = x;
      if (n < 2)
        continue;
      for (std::uint32_t x : o)
        id.emplace(x, static_cast<std::uint32_t>(id.size()));
      links.emplace_back(id[o[0]], id[o[1]]);
    }
    UnionFind uf(id.size());
    std::vector<int> degree(id.size(), 0);
    for (auto [x, y] : links)
    {
      uf.unite(x, y);
      ++degree[x];
      ++degree[y];
    }
    std::size_t parts = 0;
    bool bad_degree = false;
    for (std::uint32_t x = 0; x < id.size(); ++x)
    {
      if (uf.find(x) == x)
        ++parts;
      if (degree[x] > 2)
        bad_degree = true;
    }
    if (parts != 1 || bad_degree)
      ++topo.nonmanifold_vertices;
  }

  // Components through shared edges.
  UnionFind comp(triangles.size());
  {
    EdgeIndex index(triangles);
    const auto& pairs = index.pairs();
    for (std::size_t i = 1; i < pairs.size(); ++i)
      if (pairs[i].first == pairs[i - 1].first)
        comp.unite(pairs[i].second, pairs[i - 1].second);
  }
  for (std::uint32_t t = 0; t < triangles.size(); ++t)
    if (comp.find(t) == t)
      ++topo.components;
  return topo;
}

namespace
{

/// The tetrahedra of step 1 as flat arrays: every later pass reads these instead of chasing CGAL's
/// handles.
struct CellArrays
{
  std::uint32_t count = 0;
  std::vector<std::array<std::uint32_t, 4>> v;  ///< vertex ids (kNone: the infinite vertex)
  std::vector<std::array<std::uint32_t, 4>> n;  ///< neighbour across the facet opposite vertex k
};

/// Step 1: the Delaunay triangulation of the distinct finite points (of several at one position
/// the first in input order is the vertex). False, with `error` set, when there is no volume.
bool delaunayCells(const std::vector<Eigen::Vector3d>& points, CoconeStats& st, CellArrays& cells,
                   std::string& error)
{
  // Distinct finite points; of several at one position the first in input order is the vertex.
  std::vector<std::uint32_t> ids;
  ids.reserve(points.size());
  for (std::uint32_t i = 0; i < points.size(); ++i)
  {
    if (points[i].allFinite())
      ids.push_back(i);
    else
      ++st.non_finite_points;
  }
  std::sort(ids.begin(), ids.end(), [&](std::uint32_t a, std::uint32_t b) {
    const Eigen::Vector3d &p = points[a], &q = points[b];
    if (p.x() != q.x())
      return p.x() < q.x();
    if (p.y() != q.y())
      return p.y() < q.y();
    if (p.z() != q.z())
      return p.z() < q.z();
    return a < b;
  });
  std::vector<std::pair<K::Point_3, std::uint32_t>> input;
  input.reserve(ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k)
  {
    const Eigen::Vector3d& p = points[ids[k]];
    if (k > 0 && p == points[ids[k - 1]])
    {
      ++st.duplicate_points;
      continue;
    }
    input.emplace_back(K::Point_3(p.x(), p.y(), p.z()), ids[k]);
  }
  const std::size_t finite_count = ids.size();
  ids.clear();
  ids.shrink_to_fit();
  if (finite_count < 4)
  {
    error = "Cocone needs at least 4 finite points, got " + std::to_string(finite_count);
    return false;
  }
  // Insertion in CGAL's biased randomised Hilbert order (its shuffle has a fixed seed) with the
  // previous vertex as the hint, as CGAL's own range insertion does.
  CGAL::spatial_sort(input.begin(), input.end(),
                     CGAL::Spatial_sort_traits_adapter_3<K, CGAL::First_of_pair_property_map<std::pair<K::Point_3, std::uint32_t>>>());
  Delaunay dt;
  {
    Delaunay::Vertex_handle hint;
    for (const auto& [p, id] : input)
    {
      hint = dt.insert(p, hint == Delaunay::Vertex_handle() ? Delaunay::Cell_handle() : hint->cell());
      hint->info() = id;
    }
  }
  st.vertices = dt.number_of_vertices();
  if (dt.dimension() < 3)
  {
    error = dt.dimension() == 2   ? "the points are coplanar: they span no volume to triangulate"
            : dt.dimension() == 1 ? "the points are collinear: they span no volume to triangulate"
                                  : "all points are at the same position";
    return false;
  }
  st.delaunay_cells = dt.number_of_finite_cells();
  std::uint32_t& cell_count = cells.count;
  for (auto c = dt.all_cells_begin(); c != dt.all_cells_end(); ++c)
    c->info() = cell_count++;
  auto& cell_v = cells.v;
  auto& cell_n = cells.n;
  cell_v.resize(cell_count);
  cell_n.resize(cell_count);
  for (auto c = dt.all_cells_begin(); c != dt.all_cells_end(); ++c)
    for (int k = 0; k < 4; ++k)
    {
      const auto v = c->vertex(k);
      cell_v[c->info()][k] = dt.is_infinite(v) ? kNone : v->info();
      cell_n[c->info()][k] = c->neighbor(k)->info();
    }
  dt.clear();  // the flat arrays hold all that is needed from here on

  return true;
}

/// Step 2: per cell its circumcentre (or, on the hull, the direction of its Voronoi ray); per
/// vertex the pole axis (to the farthest circumcentre; the outward hull normal on the hull) and
/// h_p, the distance to the negative pole.
struct Poles
{
  std::vector<Eigen::Vector3d> cc;  ///< per cell: circumcentre, or ray direction
  std::vector<char> cell_kind;      ///< per cell: 0 invalid, 1 finite circumcentre, 2 infinite (ray)
  std::vector<char> is_hull, is_vertex, has_axis;  ///< per point
  std::vector<Eigen::Vector3d> axis;               ///< per point, unit where has_axis
  std::vector<double> height;                      ///< per point: h_p
};

Poles computePoles(const std::vector<Eigen::Vector3d>& points, const CellArrays& ca, CoconeStats& st)
{
  const std::size_t n = points.size();
  const std::uint32_t cell_count = ca.count;
  const auto& cell_v = ca.v;
  const auto& cell_n = ca.n;
  auto infiniteIndex = [&](std::uint32_t c) {
    for (int k = 0; k < 4; ++k)
      if (cell_v[c][k] == kNone)
        return k;
    return -1;
  };

  std::vector<Eigen::Vector3d> cc(cell_count, Eigen::Vector3d::Zero());  // circumcentre, or ray direction
  std::vector<char> cell_kind(cell_count, 0);  // 0 invalid, 1 finite circumcentre, 2 infinite (ray)
  const auto cells = static_cast<std::int64_t>(cell_count);
#pragma omp parallel for schedule(static)
  for (std::int64_t ci = 0; ci < cells; ++ci)
  {
    const auto c = static_cast<std::uint32_t>(ci);
    const auto& cv = cell_v[c];
    const int inf = infiniteIndex(c);
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
  // Hull normals are summed in a canonical order (by vertex, then facet) so that the sums do not
  // depend on CGAL's storage order.
  std::vector<Eigen::Vector3d> hull_normal(n, Eigen::Vector3d::Zero());
  std::vector<char> is_hull(n, 0);
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
      const int inf = infiniteIndex(c);
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
  // Negative pole: the farthest circumcentre on the other side of the axis; h_p its distance.
  std::vector<double> height(n, 0.0);
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
  return Poles{std::move(cc), std::move(cell_kind), std::move(is_hull), std::move(is_vertex), std::move(has_axis),
               std::move(axis), std::move(height)};
}

/// A Delaunay triangle whose dual Voronoi edge meets the cocone of at least one of its vertices.
struct Facet
{
  Triangle v;
  std::uint8_t accept;  ///< bit k: the dual edge meets vertex k's cocone
  float radius[3];      ///< how far from vertex k the edge stays in its cocone
};

/// Step 3: the cocone test of every Delaunay triangle. `radius` gets r_p per vertex: how far the
/// accepted dual edges stay in its cocone.
std::vector<Facet> coconeFacets(const std::vector<Eigen::Vector3d>& points, const CellArrays& ca, const Poles& poles,
                                const CoconeParameters& params, std::vector<double>& radius)
{
  const std::size_t n = points.size();
  const std::uint32_t cell_count = ca.count;
  const auto& cell_v = ca.v;
  const auto& cell_n = ca.n;
  const auto& cc = poles.cc;
  const auto& cell_kind = poles.cell_kind;
  const auto& has_axis = poles.has_axis;
  const auto& axis = poles.axis;
  const auto cells = static_cast<std::int64_t>(cell_count);
  std::vector<Facet> facets;
  radius.assign(n, 0.0);
  const double cos_limit = std::sin(params.cocone_angle);  // cos(π/2 − θ)
  // Facet (c, i) is visited from the cell with the smaller index; results land in a slot per
  // (cell, i), so the parallel loop gives the same array whatever the thread count.
  std::vector<Facet> slots(static_cast<std::size_t>(cell_count) * 4);
#pragma omp parallel for schedule(dynamic, 4096)
  for (std::int64_t ci = 0; ci < cells; ++ci)
  {
    const auto c = static_cast<std::uint32_t>(ci);
    for (int i = 0; i < 4; ++i)
    {
      Facet& fc = slots[static_cast<std::size_t>(c) * 4 + i];
      fc.accept = 0;
      const std::uint32_t nb = cell_n[c][i];
      if (nb < c)
        continue;
      // The facet opposite vertex i must be finite.
      const std::uint32_t f0 = cell_v[c][(i + 1) & 3], f1 = cell_v[c][(i + 2) & 3], f2 = cell_v[c][(i + 3) & 3];
      if (f0 == kNone || f1 == kNone || f2 == kNone)
        continue;
      Eigen::Vector3d start, end;
      bool ray = false;
      const char s1 = cell_kind[c], s2 = cell_kind[nb];
      if (s1 == 1 && s2 == 1)
      {
        start = cc[c];
        end = cc[nb];
      }
      else if (s1 == 1 && s2 == 2)
      {
        start = cc[c];
        end = cc[nb];
        ray = true;
      }
      else if (s1 == 2 && s2 == 1)
      {
        start = cc[nb];
        end = cc[c];
        ray = true;
      }
      else if (s1 == 1 || s2 == 1)
        start = end = (s1 == 1 ? cc[c] : cc[nb]);  // the other circumcentre is not representable
      else
        continue;
      fc.v = {f0, f1, f2};
      for (int k = 0; k < 3; ++k)
      {
        const std::uint32_t v = fc.v[k];
        fc.radius[k] = 0;
        if (!has_axis[v])
          continue;
        const CoconeHit h = coconeIntersect(points[v], axis[v], cos_limit, start, end, ray);
        if (h.hit)
        {
          fc.accept |= static_cast<std::uint8_t>(1u << k);
          fc.radius[k] = static_cast<float>(std::min<double>(h.radius, std::numeric_limits<float>::max()));
          if (std::isinf(h.radius))
            fc.radius[k] = std::numeric_limits<float>::infinity();
        }
      }
    }
  }
  for (const Facet& f : slots)
    if (f.accept)
    {
      facets.push_back(f);
      for (int k = 0; k < 3; ++k)
        if (f.accept & (1u << k))
          radius[f.v[k]] = std::max(radius[f.v[k]], static_cast<double>(f.radius[k]));
    }
  return facets;
}

/// Step 4 (Dey-Giesen): the regular samples, those whose cocone is thin and agrees with their
/// cocone neighbours'; the others are boundary samples. Without boundary detection every vertex
/// with an axis is regular.
std::vector<char> regularSamples(const std::vector<Eigen::Vector3d>& points, const Poles& poles,
                                 const std::vector<Facet>& facets, const std::vector<double>& radius,
                                 const CoconeParameters& params, CoconeStats& st)
{
  const std::size_t n = points.size();
  const auto& has_axis = poles.has_axis;
  const auto& axis = poles.axis;
  const auto& height = poles.height;
  const auto& is_vertex = poles.is_vertex;
  std::vector<char> regular(n, 0);
  for (std::uint32_t i = 0; i < n; ++i)
    regular[i] = has_axis[i];
  if (params.detect_boundaries)
  {
    std::vector<char> ratio_ok(n, 0);
    for (std::uint32_t i = 0; i < n; ++i)
    {
      const double h = height[i] > 0 ? height[i] : std::numeric_limits<double>::infinity();
      ratio_ok[i] = has_axis[i] && std::isfinite(radius[i]) && radius[i] <= params.boundary_ratio * h;
    }
    // Cocone neighbours: q is one for p when a triangle pq* passes p's cocone.
    std::vector<std::uint32_t> off(n + 1, 0);
    for (const Facet& f : facets)
      for (int k = 0; k < 3; ++k)
        if (f.accept & (1u << k))
          off[f.v[k] + 1] += 2;
    for (std::size_t i = 0; i < n; ++i)
      off[i + 1] += off[i];
    std::vector<std::uint32_t> nbr(off.back());
    std::vector<std::uint32_t> pos(off.begin(), off.end() - 1);
    for (const Facet& f : facets)
      for (int k = 0; k < 3; ++k)
        if (f.accept & (1u << k))
        {
          nbr[pos[f.v[k]]++] = f.v[(k + 1) % 3];
          nbr[pos[f.v[k]]++] = f.v[(k + 2) % 3];
        }
    const double cos_normal = std::cos(params.boundary_normal_angle);
    auto agree = [&](std::uint32_t p, std::uint32_t q) {
      return has_axis[q] && std::abs(axis[p].dot(axis[q])) >= cos_normal;
    };
    std::fill(regular.begin(), regular.end(), 0);
    std::deque<std::uint32_t> queue;
    for (std::uint32_t p = 0; p < n; ++p)
    {
      if (!ratio_ok[p] || off[p] == off[p + 1])
        continue;
      bool all = true;
      for (std::uint32_t k = off[p]; k < off[p + 1] && all; ++k)
        all = agree(p, nbr[k]);
      if (all)
      {
        regular[p] = 1;
        queue.push_back(p);
      }
    }
    while (!queue.empty())
    {
      const std::uint32_t p = queue.front();
      queue.pop_front();
      for (std::uint32_t k = off[p]; k < off[p + 1]; ++k)
      {
        const std::uint32_t q = nbr[k];
        if (!regular[q] && ratio_ok[q] && agree(p, q))
        {
          regular[q] = 1;
          queue.push_back(q);
        }
      }
    }
    for (std::uint32_t i = 0; i < n; ++i)
      st.boundary_samples += (is_vertex[i] && !regular[i]) ? 1 : 0;
  }

  return regular;
}

/// The candidate triangles: those accepted by the cocones of all their regular vertices (at least
/// one), without the ones that span a gap in the sampling, in a canonical order. `spacing` gets
/// the local sample spacing per vertex (the median candidate edge length there).
std::vector<Triangle> candidateTriangles(const std::vector<Eigen::Vector3d>& points, const std::vector<Facet>& facets,
                                         const std::vector<char>& regular, const CoconeParameters& params,
                                         CoconeStats& st, std::vector<double>& spacing)
{
  const std::size_t n = points.size();
  std::vector<Triangle> cand;
  cand.reserve(facets.size());
  for (const Facet& f : facets)
  {
    bool ok = true, any_regular = false;
    for (int k = 0; k < 3 && ok; ++k)
    {
      if (!regular[f.v[k]])
        continue;
      any_regular = true;
      ok = (f.accept >> k) & 1u;
    }
    if (ok && any_regular)
      cand.push_back(f.v);
  }
  // Local sample spacing: the median length of the candidate edges at a vertex (robust to the
  // clumps of random sampling, which make nearest-neighbour distances tiny).
  spacing.assign(n, 0.0);
  {
    std::vector<std::uint32_t> off(n + 1, 0);
    for (const Triangle& t : cand)
      for (std::uint32_t x : t)
        off[x + 1] += 2;
    for (std::size_t i = 0; i < n; ++i)
      off[i + 1] += off[i];
    std::vector<float> len(off.back());
    std::vector<std::uint32_t> pos(off.begin(), off.end() - 1);
    for (const Triangle& t : cand)
      for (int k = 0; k < 3; ++k)
      {
        const auto d = static_cast<float>((points[t[k]] - points[t[(k + 1) % 3]]).norm());
        len[pos[t[k]]++] = d;
        len[pos[t[(k + 1) % 3]]++] = d;
      }
    for (std::size_t i = 0; i < n; ++i)
    {
      if (off[i + 1] == off[i])
        continue;
      auto first = len.begin() + off[i], last = len.begin() + off[i + 1];
      auto mid = first + (last - first) / 2;
      std::nth_element(first, mid, last);
      spacing[i] = *mid;
    }
  }
  if (params.max_edge_ratio > 0)
  {
    // Undersampled spot: an edge far longer than the sample spacing at all three vertices spans a
    // gap in the sampling, not the surface.
    std::size_t kept = 0;
    for (const Triangle& t : cand)
    {
      const double local = std::max({spacing[t[0]], spacing[t[1]], spacing[t[2]]});
      const double longest = std::max({(points[t[0]] - points[t[1]]).norm(), (points[t[1]] - points[t[2]]).norm(),
                                       (points[t[2]] - points[t[0]]).norm()});
      if (longest > params.max_edge_ratio * local)
        ++st.gap_triangles;
      else
        cand[kept++] = t;
    }
    cand.resize(kept);
  }
  // Canonical order (and vertex order within a triangle) so that what follows does not depend on
  // the order in which CGAL stores its cells.
  for (Triangle& t : cand)
    std::sort(t.begin(), t.end());
  std::sort(cand.begin(), cand.end());
  st.candidate_triangles = cand.size();
  return cand;
}

/// Step 5: prune the triangles at sharp edges (an angular gap above sharp_edge_angle) and those
/// with two free edges, until none is left; returns which candidates are alive.
std::vector<char> pruneCandidates(const std::vector<Eigen::Vector3d>& points, const std::vector<Triangle>& cand,
                                  const EdgeIndex& edges, const CoconeParameters& params, CoconeStats& st)
{
  std::vector<char> alive(cand.size(), 1);
  if (params.prune)
  {
    // An edge is sharp when its live triangles leave an angular gap above sharp_edge_angle. Removing
    // triangles only widens gaps and frees edges, so a triangle once condemned stays condemned: each
    // is removed at most once, and only the neighbours of a removed triangle are looked at again.
    const double cos_open = std::cos(2 * kPi - params.sharp_edge_angle);
    std::vector<std::uint32_t> apexes, tris;
    auto liveAt = [&](std::uint32_t t, std::uint32_t a, std::uint32_t b) {
      apexes.clear();
      tris.clear();
      auto range = edges.at(t, a, b);
      for (auto it = range.first; it != range.second; ++it)
        if (alive[it->second])
        {
          tris.push_back(it->second);
          apexes.push_back(apex(cand[it->second], a, b));
        }
    };
    auto sharp = [&](std::uint32_t a, std::uint32_t b) {
      if (apexes.size() == 2)
      {
        // Two half-planes at unsigned angle φ leave gaps φ and 2π − φ.
        const Eigen::Vector3d e = (points[b] - points[a]).normalized();
        Eigen::Vector3d w1 = points[apexes[0]] - points[a], w2 = points[apexes[1]] - points[a];
        w1 -= w1.dot(e) * e;
        w2 -= w2.dot(e) * e;
        return w1.dot(w2) > cos_open * w1.norm() * w2.norm();
      }
      return largestGap(points, a, b, apexes) > params.sharp_edge_angle;
    };
    std::vector<std::uint8_t> free_edges(cand.size(), 0);
    std::vector<char> queued(cand.size(), 0);
    std::deque<std::uint32_t> work;
    auto condemn = [&](std::uint32_t t) {
      if (alive[t] && !queued[t])
      {
        queued[t] = 1;
        work.push_back(t);
      }
    };
    const auto& pairs = edges.pairs();
    for (std::size_t i = 0; i < pairs.size();)
    {
      std::size_t j = i;
      while (j < pairs.size() && pairs[j].first == pairs[i].first)
        ++j;
      const auto a = static_cast<std::uint32_t>(pairs[i].first >> 32);
      const auto b = static_cast<std::uint32_t>(pairs[i].first & 0xffffffffu);
      if (j - i == 1)
        ++free_edges[pairs[i].second];
      else
      {
        liveAt(pairs[i].second, a, b);
        if (sharp(a, b))
          for (std::size_t k = i; k < j; ++k)
            condemn(pairs[k].second);
      }
      i = j;
    }
    for (std::uint32_t t = 0; t < cand.size(); ++t)
      if (free_edges[t] >= 2)
        condemn(t);
    while (!work.empty())
    {
      const std::uint32_t t = work.front();
      work.pop_front();
      if (!alive[t])
        continue;
      alive[t] = 0;
      ++st.pruned_triangles;
      for (int k = 0; k < 3; ++k)
      {
        const std::uint32_t a = cand[t][k], b = cand[t][(k + 1) % 3];
        liveAt(t, a, b);
        if (tris.size() == 1)
        {
          if (++free_edges[tris[0]] >= 2)
            condemn(tris[0]);
        }
        else if (tris.size() >= 2 && sharp(a, b))
          for (std::uint32_t s2 : std::vector<std::uint32_t>(tris))
            condemn(s2);
      }
    }
  }
  return alive;
}

/// The walk's result: the extracted triangles in walk order (indices into the candidates) and the
/// same triangles, consistently oriented.
struct Extraction
{
  std::vector<std::uint32_t> order;
  std::vector<Triangle> out;
};

/// Step 6: walk the live candidates into oriented pieces, each edge crossed to the neighbour that
/// turns least; seeds: first the hull's extreme-x vertex, then any unused triangle.
Extraction extractSurface(const std::vector<Eigen::Vector3d>& points, const std::vector<Triangle>& cand,
                          const EdgeIndex& edges, const std::vector<char>& alive, const Poles& poles)
{
  const std::size_t n = points.size();
  const auto& is_hull = poles.is_hull;
  const auto& has_axis = poles.has_axis;
  const auto& axis = poles.axis;
  std::vector<signed char> orient(cand.size(), 0);  // +1: as stored, −1: reversed
  std::vector<std::uint32_t> order;                  // extracted triangles, in walk order
  std::vector<std::uint32_t> component_of;
  std::vector<char> vertex_used(n, 0);
  auto oriented = [&](std::uint32_t t) {
    Triangle tri = cand[t];
    if (orient[t] < 0)
      std::swap(tri[1], tri[2]);
    return tri;
  };
  auto normalOf = [&](const Triangle& tri) {
    return Eigen::Vector3d((points[tri[1]] - points[tri[0]]).cross(points[tri[2]] - points[tri[0]]));
  };
  std::uint32_t component = 0;
  auto walk = [&](std::uint32_t seed, signed char seed_orient) {
    std::deque<std::uint32_t> queue;
    orient[seed] = seed_orient;
    queue.push_back(seed);
    std::size_t count = 0;
    while (!queue.empty())
    {
      const std::uint32_t t = queue.front();
      queue.pop_front();
      order.push_back(t);
      component_of.push_back(component);
      ++count;
      const Triangle tri = oriented(t);
      const Eigen::Vector3d nrm = normalOf(tri);
      for (int k = 0; k < 3; ++k)
      {
        const std::uint32_t a = tri[k], b = tri[(k + 1) % 3], c = tri[(k + 2) % 3];
        auto range = edges.at(t, a, b);
        if (range.second - range.first < 2)
          continue;
        const Eigen::Vector3d e = (points[b] - points[a]).normalized();
        Eigen::Vector3d u = points[c] - points[a];
        u -= u.dot(e) * e;
        u.normalize();
        Eigen::Vector3d v = e.cross(u);
        if (v.dot(nrm) < 0)
          v = -v;  // turn from t towards its outside
        double best = std::numeric_limits<double>::infinity();
        std::uint32_t next = kNone;
        for (auto it = range.first; it != range.second; ++it)
        {
          const std::uint32_t s = it->second;
          if (s == t || !alive[s])
            continue;
          const double ang = halfPlaneAngle(points[a], e, points[apex(cand[s], a, b)], u, v);
          if (ang < best)
          {
            best = ang;
            next = s;
          }
        }
        if (next == kNone || orient[next] != 0)
          continue;
        // Consistent orientation: next must traverse b → a.
        const Triangle& s = cand[next];
        bool has_ba = false;
        for (int j = 0; j < 3; ++j)
          if (s[j] == b && s[(j + 1) % 3] == a)
            has_ba = true;
        orient[next] = has_ba ? 1 : -1;
        queue.push_back(next);
      }
    }
    ++component;
    return count;
  };

  // Seeds: first the live triangle at the extreme-x hull vertex, oriented along its outward axis;
  // then any live triangle none of whose vertices is used yet.
  {
    std::uint32_t best_v = kNone;
    std::vector<std::vector<std::uint32_t>> unused;
    std::vector<std::uint32_t> first_tri(n, kNone);
    for (std::uint32_t t = 0; t < cand.size(); ++t)
      if (alive[t])
        for (std::uint32_t x : cand[t])
          if (first_tri[x] == kNone)
            first_tri[x] = t;
    for (std::uint32_t v = 0; v < n; ++v)
      if (first_tri[v] != kNone && is_hull[v] && (best_v == kNone || points[v].x() > points[best_v].x()))
        best_v = v;
    auto orientFor = [&](std::uint32_t t) -> signed char {
      const Eigen::Vector3d nrm = normalOf(cand[t]);
      Eigen::Vector3d out = Eigen::Vector3d::Zero();
      for (std::uint32_t x : cand[t])
        if (is_hull[x] && has_axis[x])
          out += axis[x];
      return out.dot(nrm) < 0 ? -1 : 1;
    };
    if (best_v != kNone)
    {
      // The triangle at best_v most aligned with its axis.
      std::uint32_t seed = kNone;
      double align = -1;
      for (std::uint32_t t = 0; t < cand.size(); ++t)
      {
        if (!alive[t] || (cand[t][0] != best_v && cand[t][1] != best_v && cand[t][2] != best_v))
          continue;
        const Eigen::Vector3d nrm = normalOf(cand[t]).normalized();
        const double al = std::abs(nrm.dot(axis[best_v]));
        if (al > align)
        {
          align = al;
          seed = t;
        }
      }
      if (seed != kNone)
      {
        walk(seed, orientFor(seed));
        for (std::size_t k = 0; k < order.size(); ++k)
          for (std::uint32_t x : cand[order[k]])
            vertex_used[x] = 1;
      }
    }
    for (std::uint32_t t = 0; t < cand.size(); ++t)
    {
      if (!alive[t] || orient[t] != 0)
        continue;
      if (vertex_used[cand[t][0]] || vertex_used[cand[t][1]] || vertex_used[cand[t][2]])
        continue;
      const std::size_t before = order.size();
      walk(t, orientFor(t));
      for (std::size_t k = before; k < order.size(); ++k)
        for (std::uint32_t x : cand[order[k]])
          vertex_used[x] = 1;
    }
  }
  std::vector<Triangle> out;
  out.reserve(order.size());
  for (std::uint32_t t : order)
    out.push_back(oriented(t));
  return Extraction{std::move(order), std::move(out)};
}

/// Step 7, first part: at most two triangles per edge (the first two in walk order, if they
/// disagree in direction) and one fan per vertex (its largest); returns which triangles stay.
std::vector<char> keepManifold(const std::vector<Triangle>& out, std::size_t n)
{
  std::vector<char> keep(out.size(), 1);
  {
    // Edges: keep the first two triangles in walk order, and only if they disagree in direction.
    std::vector<std::tuple<std::uint64_t, std::uint32_t, int>> de;
    de.reserve(out.size() * 3);
    for (std::uint32_t t = 0; t < out.size(); ++t)
      for (int k = 0; k < 3; ++k)
      {
        const std::uint32_t a = out[t][k], b = out[t][(k + 1) % 3];
        de.emplace_back(edgeKey(a, b), t, a < b ? 1 : -1);
      }
    // By edge, stably: made in triangle order, and a triangle has an edge once, so this is the
    // (edge, triangle) order a sort of the tuples would give.
    radixSortStable(de, [](const std::tuple<std::uint64_t, std::uint32_t, int>& e) { return std::get<0>(e); });
    for (std::size_t i = 0; i < de.size();)
    {
      std::size_t j = i;
      while (j < de.size() && std::get<0>(de[j]) == std::get<0>(de[i]))
        ++j;
      if (j - i >= 2)
      {
        // Walk order = triangle index order: de is sorted by (key, t).
        const int d0 = std::get<2>(de[i]);
        bool have_pair = false;
        for (std::size_t k = i + 1; k < j; ++k)
        {
          if (!have_pair && std::get<2>(de[k]) == -d0)
            have_pair = true;
          else
            keep[std::get<1>(de[k])] = 0;
        }
      }
      i = j;
    }
  }
  // Vertex fans: a vertex keeps its largest fan (triangles connected through edges at it). Removing
  // a fan can split a neighbour's star, so the neighbours are looked at again (a work list).
  {
    std::vector<std::uint32_t> off(n + 1, 0);
    for (std::uint32_t t = 0; t < out.size(); ++t)
      if (keep[t])
        for (std::uint32_t x : out[t])
          ++off[x + 1];
    for (std::size_t v = 0; v < n; ++v)
      off[v + 1] += off[v];
    std::vector<std::uint32_t> star(off.back());
    std::vector<std::uint32_t> pos(off.begin(), off.end() - 1);
    for (std::uint32_t t = 0; t < out.size(); ++t)
      if (keep[t])
        for (std::uint32_t x : out[t])
          star[pos[x]++] = t;
    std::deque<std::uint32_t> work;
    std::vector<char> queued(n, 0);
    for (std::uint32_t v = 0; v < n; ++v)
      if (off[v + 1] - off[v] > 1)
      {
        work.push_back(v);
        queued[v] = 1;
      }
    std::vector<std::uint32_t> local, parent, size;
    while (!work.empty())
    {
      const std::uint32_t v = work.front();
      work.pop_front();
      queued[v] = 0;
      local.clear();
      for (std::uint32_t k = off[v]; k < off[v + 1]; ++k)
        if (keep[star[k]])
          local.push_back(star[k]);
      const auto m = static_cast<std::uint32_t>(local.size());
      if (m <= 1)
        continue;
      parent.resize(m);
      std::iota(parent.begin(), parent.end(), 0u);
      auto find = [&](std::uint32_t x) {
        while (parent[x] != x)
          x = parent[x] = parent[parent[x]];
        return x;
      };
      for (std::uint32_t i = 0; i < m; ++i)
        for (std::uint32_t j = i + 1; j < m; ++j)
        {
          const Triangle& ti = out[local[i]];
          const Triangle& tj = out[local[j]];
          bool shared = false;
          for (std::uint32_t x : ti)
            if (x != v && (x == tj[0] || x == tj[1] || x == tj[2]))
              shared = true;
          if (shared)
          {
            const std::uint32_t ri = find(i), rj = find(j);
            if (ri != rj)
              parent[std::max(ri, rj)] = std::min(ri, rj);
          }
        }
      size.assign(m, 0);
      for (std::uint32_t i = 0; i < m; ++i)
        ++size[find(i)];
      std::uint32_t best = 0;
      for (std::uint32_t i = 1; i < m; ++i)
        if (size[i] > size[best])
          best = i;
      for (std::uint32_t i = 0; i < m; ++i)
        if (find(i) != best)
        {
          keep[local[i]] = 0;
          for (std::uint32_t x : out[local[i]])
            if (x != v && !queued[x])
            {
              queued[x] = 1;
              work.push_back(x);
            }
        }
    }
  }
  return keep;
}

/// Step 7, second part: triangles added to the kept mesh, with the use of every edge tracked.
class MeshFill
{
public:
  MeshFill(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& spacing,
           const CoconeParameters& params, std::vector<Triangle>& out, std::vector<char>& keep, CoconeStats& st)
    : points_(points), spacing_(spacing), params_(params), out_(out), keep_(keep), st_(st)
  {
    use_.reserve(out.size() * 2);
    for (std::uint32_t i = 0; i < out.size(); ++i)
      if (keep[i])
        addEdges(out[i]);
  }

  /// Close notches and small holes with candidate triangles: a candidate whose orientation matches
  /// at least two current boundary edges (and whose third edge is free or a matching boundary edge)
  /// is added. This keeps the mesh manifold and mends the places where the walk met a sliver from
  /// two sides and the clean-up had to drop a triangle.
  void fillNotches(const std::vector<Triangle>& cand, const std::vector<char>& alive, const EdgeIndex& edges,
                   const std::vector<std::uint32_t>& order)
  {
    auto& out = out_;
    auto& keep = keep_;
    auto& use = use_;
    auto& st = st_;
  {
    std::vector<char> in_mesh(cand.size(), 0);
    for (std::uint32_t i = 0; i < out.size(); ++i)
      if (keep[i])
        in_mesh[order[i]] = 1;
    // First every candidate, then only those next to a triangle just added.
    std::vector<std::uint32_t> frontier;
    for (std::uint32_t t = 0; t < cand.size(); ++t)
      if (alive[t] && !in_mesh[t])
        frontier.push_back(t);
    while (!frontier.empty())
    {
      std::vector<std::uint32_t> next_frontier;
      for (std::uint32_t t : frontier)
      {
        if (in_mesh[t])
          continue;
        for (int flip = 0; flip < 2; ++flip)
        {
          Triangle tri = cand[t];
          if (flip)
            std::swap(tri[1], tri[2]);
          int matched = 0;
          bool ok = true;
          for (int k = 0; k < 3 && ok; ++k)
          {
            const auto it = use.find(edgeKey(tri[k], tri[(k + 1) % 3]));
            if (it == use.end() || it->second.count == 0)
              continue;
            if (it->second.count == 1 && it->second.from == tri[(k + 1) % 3])
              ++matched;
            else
              ok = false;
          }
          if (ok && matched >= 2)
          {
            in_mesh[t] = 1;
            out.push_back(tri);
            keep.push_back(1);
            addEdges(tri);
            ++st.filled_triangles;
            for (int k = 0; k < 3; ++k)
            {
              auto range = edges.at(t, tri[k], tri[(k + 1) % 3]);
              for (auto it = range.first; it != range.second; ++it)
                if (alive[it->second] && !in_mesh[it->second])
                  next_frontier.push_back(it->second);
            }
            break;
          }
        }
      }
      std::sort(next_frontier.begin(), next_frontier.end());
      next_frontier.erase(std::unique(next_frontier.begin(), next_frontier.end()), next_frontier.end());
      frontier.swap(next_frontier);
    }
  }
  }

  /// Holes (boundary loops of at most max_edges edges) are closed by ear clipping, shortest new
  /// edge first; a loop whose ears would all create an existing edge (or, with the ratio guard, an
  /// edge longer than max_edge_ratio × the local spacing: a gap in the sampling) is left open.
  /// Returns the number of loops closed.
  std::size_t closeLoops(std::size_t max_edges, bool ratio_guard)
  {
    const auto& points = points_;
    const auto& spacing = spacing_;
    const auto& params = params_;
    auto& out = out_;
    auto& keep = keep_;
    auto& use = use_;
    auto& st = st_;
    // Hole edges: existing a → b gives hole edge b → a. A vertex with two outgoing hole edges (two
    // openings meeting at it) is ambiguous: loops through it are left alone.
    std::unordered_map<std::uint32_t, std::uint32_t> hole_next;
    std::unordered_set<std::uint32_t> ambiguous;
    std::vector<std::uint32_t> starts;
    for (const auto& [key, u] : use)
    {
      if (u.count != 1)
        continue;
      const auto lo = static_cast<std::uint32_t>(key >> 32), hi = static_cast<std::uint32_t>(key & 0xffffffffu);
      const std::uint32_t a = u.from, b = (a == lo ? hi : lo);
      if (!hole_next.emplace(b, a).second)
        ambiguous.insert(b);
      starts.push_back(b);
    }
    std::sort(starts.begin(), starts.end());
    std::unordered_set<std::uint32_t> visited;
    std::size_t closed_loops = 0;
    for (std::uint32_t s0 : starts)
    {
      if (visited.count(s0))
        continue;
      std::vector<std::uint32_t> loop;
      std::uint32_t v = s0;
      bool closed = false;
      while (loop.size() <= max_edges)
      {
        if (ambiguous.count(v))
          break;
        visited.insert(v);
        loop.push_back(v);
        const auto it = hole_next.find(v);
        if (it == hole_next.end())
          break;
        v = it->second;
        if (v == s0)
        {
          closed = true;
          break;
        }
        if (visited.count(v))
          break;
      }
      if (!closed || loop.size() < 3 || loop.size() > max_edges)
        continue;
      std::vector<Triangle> added;
      std::unordered_set<std::uint64_t> chords;
      // Newell normal of the loop, in the orientation the new triangles take: convex ears first, so
      // that the seal does not fold over itself.
      Eigen::Vector3d loop_normal = Eigen::Vector3d::Zero();
      for (std::size_t i = 0; i < loop.size(); ++i)
        loop_normal += points[loop[i]].cross(points[loop[(i + 1) % loop.size()]]);
      while (loop.size() > 3)
      {
        double best = std::numeric_limits<double>::infinity();
        std::size_t best_i = loop.size();
        for (int pass = 0; pass < 2 && best_i == loop.size(); ++pass)
        for (std::size_t i = 0; i < loop.size(); ++i)
        {
          const std::uint32_t prev = loop[(i + loop.size() - 1) % loop.size()], next = loop[(i + 1) % loop.size()];
          const std::uint64_t key = edgeKey(prev, next);
          if (use.count(key) || chords.count(key))
            continue;
          const double len = (points[prev] - points[next]).squaredNorm();
          if (pass == 0 &&
              (points[loop[i]] - points[prev]).cross(points[next] - points[prev]).dot(loop_normal) <= 0)
            continue;  // a reflex ear: only when no convex one is left
          if (ratio_guard && params.max_edge_ratio > 0)
          {
            const double local = std::max({spacing[prev], spacing[loop[i]], spacing[next]});
            if (len > params.max_edge_ratio * params.max_edge_ratio * local * local)
              continue;
          }
          if (len < best)
          {
            best = len;
            best_i = i;
          }
        }
        if (best_i == loop.size())
          break;
        const std::uint32_t prev = loop[(best_i + loop.size() - 1) % loop.size()], cur = loop[best_i],
                            next = loop[(best_i + 1) % loop.size()];
        added.push_back({prev, cur, next});
        chords.insert(edgeKey(prev, next));
        loop.erase(loop.begin() + static_cast<std::ptrdiff_t>(best_i));
      }
      if (loop.size() != 3)
        continue;  // nothing of this loop is committed
      added.push_back({loop[0], loop[1], loop[2]});
      for (const Triangle& tri : added)
      {
        out.push_back(tri);
        keep.push_back(1);
        addEdges(tri);
        ++st.filled_triangles;
      }
      ++closed_loops;
    }
    return closed_loops;
  }

private:
  struct EdgeUse
  {
    int count = 0;
    std::uint32_t from = 0;  // for one triangle: the edge is traversed from -> other
  };
  void addEdges(const Triangle& tri)
  {
    for (int k = 0; k < 3; ++k)
    {
      EdgeUse& u = use_[edgeKey(tri[k], tri[(k + 1) % 3])];
      ++u.count;
      u.from = tri[k];
    }
  }

  const std::vector<Eigen::Vector3d>& points_;
  const std::vector<double>& spacing_;
  const CoconeParameters& params_;
  std::vector<Triangle>& out_;
  std::vector<char>& keep_;
  CoconeStats& st_;
  std::unordered_map<std::uint64_t, EdgeUse> use_;
};

/// Step 7, last part: the components (through shared edges) of what is kept; those of fewer than
/// min_component_triangles triangles are dropped.
std::vector<Triangle> keepLargeComponents(const std::vector<Triangle>& out, const std::vector<char>& keep,
                                          const CoconeParameters& params, CoconeStats& st)
{
  std::vector<Triangle> result;
  {
    std::vector<Triangle> kept;
    for (std::uint32_t t = 0; t < out.size(); ++t)
      if (keep[t])
        kept.push_back(out[t]);
    UnionFind uf(kept.size());
    const EdgeIndex index(kept);
    const auto& pairs = index.pairs();
    for (std::size_t i = 1; i < pairs.size(); ++i)
      if (pairs[i].first == pairs[i - 1].first)
        uf.unite(pairs[i].second, pairs[i - 1].second);
    std::vector<std::size_t> size(kept.size(), 0);
    for (std::uint32_t t = 0; t < kept.size(); ++t)
      ++size[uf.find(t)];
    const std::size_t min_size = std::max<std::size_t>(params.min_component_triangles, 1);
    for (std::uint32_t t = 0; t < kept.size(); ++t)
    {
      if (uf.find(t) == t && size[t] >= min_size)
        ++st.components;
      if (size[uf.find(t)] >= min_size)
        result.push_back(kept[t]);
    }
  }
  return result;
}

}  // namespace

CoconeResult coconeReconstruct(const std::vector<Eigen::Vector3d>& points, const CoconeParameters& params)
{
  CoconeResult result;
  CoconeStats& st = result.stats;
  const auto t_start = Clock::now();
  st.input_points = points.size();
  if (const std::string why = params.validate(); !why.empty())
  {
    result.error = "invalid Cocone parameters: " + why;
    return result;
  }
  if (points.size() >= kNone)
  {
    result.error = "too many points for 32-bit indices";
    return result;
  }
  const std::size_t n = points.size();

  auto t0 = Clock::now();
  CellArrays cells;
  if (!delaunayCells(points, st, cells, result.error))
  {
    st.time_total = since(t_start);
    return result;
  }
  st.time_delaunay = since(t0);

  t0 = Clock::now();
  Poles poles = computePoles(points, cells, st);
  st.time_poles = since(t0);

  t0 = Clock::now();
  std::vector<double> radius, spacing;
  std::vector<Facet> facets = coconeFacets(points, cells, poles, params, radius);
  cells = CellArrays{};
  poles.cc = {};
  poles.cell_kind = {};
  const std::vector<char> regular = regularSamples(points, poles, facets, radius, params, st);
  const std::vector<Triangle> cand = candidateTriangles(points, facets, regular, params, st, spacing);
  facets = {};
  st.time_cocone = since(t0);

  t0 = Clock::now();
  const EdgeIndex edges(cand);
  const std::vector<char> alive = pruneCandidates(points, cand, edges, params, st);
  st.time_prune = since(t0);

  t0 = Clock::now();
  Extraction walked = extractSurface(points, cand, edges, alive, poles);
  st.extracted_triangles = walked.order.size();
  st.time_extract = since(t0);

  t0 = Clock::now();
  std::vector<Triangle>& out = walked.out;
  std::vector<char> keep = keepManifold(out, n);
  MeshFill fill(points, spacing, params, out, keep, st);
  fill.fillNotches(cand, alive, edges, walked.order);
  if (params.fill_hole_edges >= 3)
    fill.closeLoops(params.fill_hole_edges, true);
  if (params.watertight)
    st.sealed_loops = fill.closeLoops(std::numeric_limits<std::size_t>::max() - 1, false);
  result.triangles = keepLargeComponents(out, keep, params, st);
  st.cleanup_removed_triangles = st.extracted_triangles + st.filled_triangles - result.triangles.size();
  st.time_cleanup = since(t0);
  st.triangles = result.triangles.size();
  {
    std::vector<char> used(n, 0);
    for (const Triangle& t : result.triangles)
      for (std::uint32_t x : t)
        used[x] = 1;
    st.used_vertices = static_cast<std::size_t>(std::count(used.begin(), used.end(), 1));
  }
  st.time_total = since(t_start);
  if (result.triangles.empty())
    result.error = "no surface found: no Delaunay triangle passed the cocone test";
  return result;
}

}  // namespace surface
}  // namespace pcl_ecs
