// cocone_detail.h — what the steps of the Cocone reconstruction (cocone.h) share: the flat arrays
// between steps, the edge index, small geometric helpers and the steps' functions, one source
// file each (cocone_delaunay.cpp, cocone_poles.cpp, cocone_test.cpp, cocone_extract.cpp,
// cocone_cleanup.cpp; cocone.cpp runs them in order). Not installed.
#pragma once

#include <pcl_ecs/surface/cocone.h>

#include "../detail/flat_key_map.h"
#include "../detail/radix_sort.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

namespace pcl_ecs
{
namespace surface
{
namespace detail
{
constexpr double kPi = 3.14159265358979323846;
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

using Clock = std::chrono::steady_clock;
inline double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

inline std::uint64_t edgeKey(std::uint32_t a, std::uint32_t b)
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
inline double halfPlaneAngle(const Eigen::Vector3d& a, const Eigen::Vector3d& e, const Eigen::Vector3d& c,
                      const Eigen::Vector3d& u, const Eigen::Vector3d& v)
{
  Eigen::Vector3d w = c - a;
  w -= w.dot(e) * e;
  double ang = std::atan2(w.dot(v), w.dot(u));
  if (ang <= 0)
    ang += 2 * kPi;
  return ang;
}

/** Whether triangle t has v as a corner. */
inline bool holds(const Triangle& t, std::uint32_t v)
{
  return t[0] == v || t[1] == v || t[2] == v;
}

/** The position (0-2) of v in triangle t, which holds it. */
inline int cornerOf(const Triangle& t, std::uint32_t v)
{
  return t[0] == v ? 0 : t[1] == v ? 1 : 2;
}

/** The vertex of triangle t that is not a or b. */
inline std::uint32_t apex(const Triangle& t, std::uint32_t a, std::uint32_t b)
{
  for (std::uint32_t x : t)
    if (x != a && x != b)
      return x;
  return t[0];
}

/// The triangles around every vertex (compressed rows): star[offset[v] .. offset[v + 1]) are the
/// triangles holding v, in triangle order; only the triangles t with keep[t] when `keep` is given.
struct VertexStars
{
  std::vector<std::uint32_t> offset, star;
};

inline VertexStars vertexStars(std::size_t num_points, const std::vector<Triangle>& triangles,
                               const std::vector<char>* keep = nullptr)
{
  VertexStars s;
  s.offset.assign(num_points + 1, 0);
  for (std::uint32_t t = 0; t < triangles.size(); ++t)
    if (!keep || (*keep)[t])
      for (std::uint32_t x : triangles[t])
        ++s.offset[x + 1];
  for (std::size_t v = 0; v < num_points; ++v)
    s.offset[v + 1] += s.offset[v];
  s.star.resize(s.offset.back());
  std::vector<std::uint32_t> fill(s.offset.begin(), s.offset.end() - 1);
  for (std::uint32_t t = 0; t < triangles.size(); ++t)
    if (!keep || (*keep)[t])
      for (std::uint32_t x : triangles[t])
        s.star[fill[x]++] = t;
  return s;
}

/// The triangle across each side of every kept triangle: nbr[3 t + k] is the kept triangle that
/// shares side k of t (from triangles[t][k] to triangles[t][k + 1]) when exactly two kept triangles
/// have that edge, kNone otherwise (a boundary, or more than two). `stars` come from
/// vertexStars(num_points, triangles, keep); unkept triangles get kNone on every side.
inline std::vector<std::uint32_t> sideNeighbours(const std::vector<Triangle>& triangles, const VertexStars& stars)
{
  const std::size_t n = stars.offset.size() - 1;
  std::vector<std::uint32_t> nbr(3 * triangles.size(), kNone);
  auto sideOf = [&](std::uint32_t t, std::uint32_t a, std::uint32_t b) {
    const Triangle& tri = triangles[t];
    const int k = cornerOf(tri, a);
    return tri[(k + 1) % 3] == b ? k : (k + 2) % 3;
  };
  // At each vertex a, the triangles of its star holding b (b > a, so each edge once), counted: an
  // edge ab held by exactly two joins them across their sides on it. seen[b] == a marks b as met
  // at a; first[b] and second[b] are the first two triangles met there.
  std::vector<std::uint32_t> seen(n, kNone), first(n), second(n), holders(n);
  for (std::uint32_t a = 0; a < n; ++a)
  {
    for (std::uint32_t i = stars.offset[a]; i < stars.offset[a + 1]; ++i)
    {
      const std::uint32_t t = stars.star[i];
      for (const std::uint32_t b : triangles[t])
      {
        if (b <= a)
          continue;
        if (seen[b] != a)
        {
          seen[b] = a;
          first[b] = t;
          holders[b] = 1;
        }
        else if (++holders[b] == 2)
          second[b] = t;
      }
    }
    for (std::uint32_t i = stars.offset[a]; i < stars.offset[a + 1]; ++i)
      for (const std::uint32_t b : triangles[stars.star[i]])
        if (b > a && holders[b] == 2 && first[b] == stars.star[i])
        {
          const std::uint32_t t0 = first[b], t1 = second[b];
          nbr[3 * static_cast<std::size_t>(t0) + static_cast<std::size_t>(sideOf(t0, a, b))] = t1;
          nbr[3 * static_cast<std::size_t>(t1) + static_cast<std::size_t>(sideOf(t1, a, b))] = t0;
        }
  }
  return nbr;
}

/// Triangles in lexicographic order of their corners (each over `num_points` vertices): a radix
/// sort on the corners packed into one key when they fit, else a comparison sort (one result).
inline void sortTriangles(std::vector<Triangle>& triangles, std::size_t num_points)
{
  int bits = 1;
  while (bits < 32 && (std::size_t{1} << bits) < num_points)
    ++bits;
  if (3 * bits > 64)
  {
    std::sort(triangles.begin(), triangles.end());
    return;
  }
  radixSortStable(triangles, [bits](const Triangle& t) {
    return (static_cast<std::uint64_t>(t[0]) << (2 * bits)) | (static_cast<std::uint64_t>(t[1]) << bits) | t[2];
  });
}

/// How an edge of the mesh is used: by how many triangles, and for one, the corner it leaves from.
struct EdgeUse
{
  int count = 0;
  std::uint32_t from = 0;  // for one triangle: the edge is traversed from -> other
};

/// Edge key (edgeKey) → EdgeUse, in one flat array: the clean-up adds and looks up every edge of
/// the mesh, which a node-based map pays an allocation each for.
using EdgeUseMap = FlatKeyMap<EdgeUse>;

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
inline double largestGap(const std::vector<Eigen::Vector3d>& pts, std::uint32_t a, std::uint32_t b,
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


/// The tetrahedra of step 1 as flat arrays: every later pass reads these instead of chasing CGAL's
/// handles.
struct CellArrays
{
  std::uint32_t count = 0;
  std::vector<std::array<std::uint32_t, 4>> v;  ///< vertex ids (kNone: the infinite vertex)
  std::vector<std::array<std::uint32_t, 4>> n;  ///< neighbour across the facet opposite vertex k
};


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


/// A Delaunay triangle whose dual Voronoi edge meets the cocone of at least one of its vertices.
struct Facet
{
  Triangle v;
  std::uint8_t accept;  ///< bit k: the dual edge meets vertex k's cocone
  float radius[3];      ///< how far from vertex k the edge stays in its cocone
};


/// The walk's result: the extracted triangles in walk order (indices into the candidates) and the
/// same triangles, consistently oriented.
struct Extraction
{
  std::vector<std::uint32_t> order;
  std::vector<Triangle> out;
};

/// Step 1: the Delaunay triangulation of the distinct finite points (of several at one position
/// the first in input order is the vertex). False, with `error` set, when there is no volume.
bool delaunayCells(const std::vector<Eigen::Vector3d>& points, CoconeStats& st, CellArrays& cells,
                   std::string& error);

/// Step 2: the poles of every vertex (Poles).
Poles computePoles(const std::vector<Eigen::Vector3d>& points, const CellArrays& ca, CoconeStats& st);

/// Step 3: the cocone test of every Delaunay triangle. `radius` gets r_p per vertex: how far the
/// accepted dual edges stay in its cocone.
std::vector<Facet> coconeFacets(const std::vector<Eigen::Vector3d>& points, const CellArrays& ca, const Poles& poles,
                                const CoconeParameters& params, std::vector<double>& radius);

/// Step 4 (Dey-Giesen): the regular samples, those whose cocone is thin and agrees with their
/// cocone neighbours'; the others are boundary samples. Without boundary detection every vertex
/// with an axis is regular.
std::vector<char> regularSamples(const std::vector<Eigen::Vector3d>& points, const Poles& poles,
                                 const std::vector<Facet>& facets, const std::vector<double>& radius,
                                 const CoconeParameters& params, CoconeStats& st);

/// The radius each sample is judged by in the ball-overlap rule: its own when positive and finite;
/// for a sample of radius exactly 0 (a point the filter kept as it is), the radius of its nearest
/// neighbour across `facets` that has one (ties: the larger); 0 (unknown) otherwise.
std::vector<double> overlapRadii(const std::vector<Eigen::Vector3d>& points, const std::vector<Facet>& facets,
                                 const std::vector<double>& sample_radius);

/// The candidate triangles: those accepted by the cocones of all their regular vertices (at least
/// one), without the ones that span a gap in the sampling or, given `sample_radius` (per point, or
/// empty), join two balls that do not overlap (overlapRadii), in a canonical order. `spacing` gets the local
/// sample spacing per vertex (the median candidate edge length there).
std::vector<Triangle> candidateTriangles(const std::vector<Eigen::Vector3d>& points, const std::vector<Facet>& facets,
                                         const std::vector<char>& regular, const CoconeParameters& params,
                                         CoconeStats& st, std::vector<double>& spacing, const std::vector<double>& sample_radius);

/// Step 5: prune the triangles at sharp edges (an angular gap above sharp_edge_angle) and those
/// with two free edges, until none is left; returns which candidates are alive.
std::vector<char> pruneCandidates(const std::vector<Eigen::Vector3d>& points, const std::vector<Triangle>& cand,
                                  const EdgeIndex& edges, const CoconeParameters& params, CoconeStats& st);

/// Step 6: walk the live candidates into oriented pieces, each edge crossed to the neighbour that
/// turns least, best first (the flattest crossing first); seeds: first the hull's two extreme-x
/// vertices (walked together), then any unused triangle.
Extraction extractSurface(const std::vector<Eigen::Vector3d>& points, const std::vector<Triangle>& cand,
                          const EdgeIndex& edges, const std::vector<char>& alive, const Poles& poles);

/// Whether a boundary loop is a slit between two rows of samples rather than a gap in the
/// sampling: its area over its longest chord (its width) is below half the smallest `spacing` at
/// its vertices. The hole filling closes a slit the gap guard stopped (MeshFill::closeLoops).
bool isSlit(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& spacing,
            const std::vector<std::uint32_t>& loop);

/// A cycle of three mesh edges around a handle runs around a thin part of the object, sampled
/// around its girth, when its longest edge is below this fraction of the smallest sample spacing
/// at its vertices: its three samples lie closer to each other than to the samples around them.
/// The handles the walk makes between two sheets cross a gap of a spacing or more. The clean-up
/// keeps such a handle (MeshFill::removeSmallHandles). On the closed shapes at 10% and 3% the
/// one handle of this kind (the elephant at 3%, a thin solid bridge) has its longest edge at 0.54
/// × that spacing, the eleven handles the walk made (the camelhead, the joint, the pinion, the spool)
/// at 1.32 × or more; any fraction from 0.6 to 1.25 cuts the same ones there.
constexpr double kThinPartGirth = 0.75;

/// Step 7, first part: at most two triangles per edge (the first two in triangle order, if they
/// disagree in direction) and one fan per vertex (its largest: the first of the largest, by its
/// first triangle in the vertex's star; a vertex whose fans change is looked at again); returns
/// which triangles stay (cocone_cleanup.cpp).
std::vector<char> keepManifold(const std::vector<Triangle>& out, std::size_t n);

/// Step 7, last part: the components (through shared edges) of the triangles t with keep[t];
/// those of fewer than params.min_component_triangles triangles are dropped, and so are the second
/// layers over the largest one: a closed piece of at most 1% of its triangles whose every vertex
/// lies within half its local spacing (`spacing`) of the largest piece's triangles (a pocket of a
/// few samples the hole filling closed beside the surface they lie on; st.dropped_layers counts
/// them). st.components counts the pieces kept. `side_neighbours` is
/// sideNeighbours(out, vertexStars(points.size(), out, &keep)), numbered like `out` (the clean-up
/// passes the table its edge flips kept up to date).
std::vector<Triangle> keepLargeComponents(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& spacing,
                                          const std::vector<Triangle>& out, const std::vector<char>& keep,
                                          const std::vector<std::uint32_t>& side_neighbours,
                                          const CoconeParameters& params, CoconeStats& st);

/// Step 7: the walked triangles made an oriented 2-manifold (at most two triangles an edge, one
/// fan a vertex), notches and small holes closed, tunnels opened where `support` (the scan, its
/// sample_of empty or checked; may be empty) shows them, loops sealed when asked, small components
/// dropped (cocone_cleanup.cpp).
std::vector<Triangle> cleanUp(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& spacing,
                              const CoconeParameters& params, const std::vector<Triangle>& cand,
                              const std::vector<char>& alive, const EdgeIndex& edges, Extraction& walked,
                              const ScanSupport& support, CoconeStats& st);

}  // namespace detail
}  // namespace surface
}  // namespace pcl_ecs
