// cocone.cpp — the Cocone reconstruction (cocone.h): its steps in order (one file each, see
// cocone_detail.h), the cocone test of one point and the mesh topology.
#include "cocone_detail.h"

#include <algorithm>
#include <sstream>

namespace pcl_ecs
{
namespace surface
{
using namespace detail;

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

namespace
{
/// Vertices whose triangles do not form one fan (connected through edges at the vertex): the
/// link of each vertex must be a single path or cycle.
std::size_t countNonManifoldVertices(std::size_t num_points, const std::vector<Triangle>& triangles)
{
  std::size_t bad = 0;
  const VertexStars stars = vertexStars(num_points, triangles);
  const std::vector<std::uint32_t>& offset = stars.offset;
  const std::vector<std::uint32_t>& star = stars.star;
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
      ++bad;
  }

  return bad;
}
}  // namespace

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
  topo.nonmanifold_vertices = countNonManifoldVertices(num_points, triangles);

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


CoconeResult coconeReconstruct(const std::vector<Eigen::Vector3d>& points, const CoconeParameters& params,
                               const std::vector<double>& sample_radius, const ScanSupport& support)
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
  if (!sample_radius.empty() && sample_radius.size() != points.size())
  {
    result.error = "sample radii for " + std::to_string(sample_radius.size()) + " points, but there are " +
                   std::to_string(points.size()) + " points";
    return result;
  }
  if (support.points.size() >= kNone)
  {
    result.error = "too many scan points for 32-bit indices";
    return result;
  }
  if (!support.sample_of.empty())
  {
    if (support.sample_of.size() != support.points.size())
    {
      result.error = "the scan's sample_of has " + std::to_string(support.sample_of.size()) + " entries for " +
                     std::to_string(support.points.size()) + " scan points";
      return result;
    }
    for (std::size_t i = 0; i < support.sample_of.size(); ++i)
      if (support.sample_of[i] < -1 || support.sample_of[i] >= static_cast<std::int64_t>(points.size()))
      {
        result.error = "the scan's sample_of[" + std::to_string(i) + "] = " + std::to_string(support.sample_of[i]) +
                       " names no sample (there are " + std::to_string(points.size()) + ")";
        return result;
      }
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
  const std::vector<Triangle> cand = candidateTriangles(points, facets, regular, params, st, spacing, sample_radius);
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
  result.triangles = cleanUp(points, spacing, params, cand, alive, edges, walked, support, st);
  st.cleanup_removed_triangles = st.extracted_triangles + st.filled_triangles + st.stitched_triangles +
                                 st.tunnel_triangles - result.triangles.size();
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
