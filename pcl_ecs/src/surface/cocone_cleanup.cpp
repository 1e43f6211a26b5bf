// cocone_cleanup.cpp — step 7 of the Cocone reconstruction (cocone.h): an oriented 2-manifold,
// notches and holes closed, tunnels opened against the scan when asked, loops sealed when asked,
// small components dropped.
#include "cocone_detail.h"
#include "../detail/point_grid.h"

#include <cstring>
#include <deque>
#include <functional>
#include <optional>
#include <queue>
#include <unordered_map>
#include <unordered_set>

namespace pcl_ecs
{
namespace surface
{
namespace detail
{

namespace
{
/// The pieces of the kept triangles, as a union of their vertices.
UnionFind vertexPieces(std::size_t num_points, const std::vector<Triangle>& out, const std::vector<char>& keep)
{
  UnionFind uf(num_points);
  for (std::uint32_t t = 0; t < out.size(); ++t)
    if (keep[t])
    {
      uf.unite(out[t][0], out[t][1]);
      uf.unite(out[t][0], out[t][2]);
    }
  return uf;
}

/// Step 7, second part: the orientation of the pieces the manifold clean-up leaves. A piece can
/// come out inside out: the walk crossed a fold (a sliver where two sheets meet) and went on with
/// the other side up, and the clean-up then cut the fold, or the piece was walked from a seed with
/// no hull vertex to orient it. Each piece after the first (the one holding the walk's first kept
/// triangle, oriented at the hull) takes the orientation of the pieces settled around it, largest
/// first: its vertex normals are compared with the settled vertices' within 3 local spacings (at
/// most 9 median spacings) that lie along its tangent plane, at most 60° off it seen from either
/// end (not across a thin part, whose two sheets face opposite ways), and the piece is reversed
/// when they disagree on balance. Returns the number of pieces reversed.
std::size_t orientPieces(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& spacing,
                         std::vector<Triangle>& out, const std::vector<char>& keep)
{
  // The pieces: components of the kept triangles. After keepManifold two triangles at an edge run
  // it in opposite directions and a vertex has one fan, so each piece is consistently oriented, and
  // pieces through shared vertices are pieces through shared edges.
  std::vector<std::uint32_t> kept;
  for (std::uint32_t t = 0; t < out.size(); ++t)
    if (keep[t])
      kept.push_back(t);
  if (kept.empty())
    return 0;
  const std::size_t n = points.size();
  UnionFind uf = vertexPieces(n, out, keep);
  // Piece ids in walk order of their first triangle (piece 0 holds the walk's first kept
  // triangle, which the hull seed oriented); members listed piece by piece.
  std::vector<std::uint32_t> id(kept.size(), kNone), root_id(n, kNone);
  std::uint32_t pieces = 0;
  for (std::uint32_t k = 0; k < kept.size(); ++k)
  {
    const std::uint32_t r = uf.find(out[kept[k]][0]);
    if (root_id[r] == kNone)
      root_id[r] = pieces++;
    id[k] = root_id[r];
  }
  if (pieces < 2)
    return 0;
  std::vector<std::uint32_t> first(pieces + 1, 0);
  for (std::uint32_t c : id)
    ++first[c + 1];
  for (std::uint32_t c = 0; c < pieces; ++c)
    first[c + 1] += first[c];
  std::vector<std::uint32_t> member(kept.size());
  {
    std::vector<std::uint32_t> fill(first.begin(), first.end() - 1);
    for (std::uint32_t k = 0; k < kept.size(); ++k)
      member[fill[id[k]]++] = kept[k];
  }
  std::vector<std::uint32_t> rank(pieces);
  std::iota(rank.begin(), rank.end(), 0u);
  std::stable_sort(rank.begin() + 1, rank.end(), [&](std::uint32_t x, std::uint32_t y) {
    return first[x + 1] - first[x] > first[y + 1] - first[y];
  });

  // A grid over the used vertices, cells of 3 median spacings.
  std::vector<char> mark(n, 0);
  std::vector<std::uint32_t> used;
  for (std::uint32_t t : kept)
    for (std::uint32_t x : out[t])
      if (!mark[x])
      {
        mark[x] = 1;
        used.push_back(x);
      }
  std::vector<double> sp;
  for (std::uint32_t x : used)
    if (spacing[x] > 0 && std::isfinite(spacing[x]))
      sp.push_back(spacing[x]);
  if (sp.empty())
    return 0;
  std::nth_element(sp.begin(), sp.begin() + static_cast<std::ptrdiff_t>(sp.size() / 2), sp.end());
  Eigen::Vector3d lo = points[used[0]], hi = lo;
  for (std::uint32_t x : used)
  {
    lo = lo.cwiseMin(points[x]);
    hi = hi.cwiseMax(points[x]);
  }
  const double h = std::max(3 * sp[sp.size() / 2], (hi - lo).maxCoeff() / double(1 << 20));
  auto cellOf = [&](const Eigen::Vector3d& p) {
    return Eigen::Vector3i(static_cast<int>((p.x() - lo.x()) / h), static_cast<int>((p.y() - lo.y()) / h),
                           static_cast<int>((p.z() - lo.z()) / h));
  };
  auto keyOf = [](int x, int y, int z) {
    return (static_cast<std::uint64_t>(x) << 42) | (static_cast<std::uint64_t>(y) << 21) |
           static_cast<std::uint64_t>(z);
  };
  auto radiusAt = [&](std::uint32_t p) { return std::min(3 * spacing[p], 3 * h); };
  // The keys of the cells within radiusAt(p) of vertex p (none for a radius that is not positive).
  auto forCellsNear = [&](std::uint32_t p, auto&& visit) {
    const double r = radiusAt(p);
    if (!(r > 0))
      return;
    const Eigen::Vector3i c0 = cellOf(points[p] - Eigen::Vector3d::Constant(r)),
                          c1 = cellOf(points[p] + Eigen::Vector3d::Constant(r));
    for (int x = std::max(c0.x(), 0); x <= c1.x(); ++x)
      for (int y = std::max(c0.y(), 0); y <= c1.y(); ++y)
        for (int z = std::max(c0.z(), 0); z <= c1.z(); ++z)
          visit(keyOf(x, y, z));
  };
  // The used vertices by cell, stably (the vertices of a cell in order of first use: a fixed
  // order of the votes).
  std::vector<std::pair<std::uint64_t, std::uint32_t>> grid;
  grid.reserve(used.size());
  for (std::uint32_t x : used)
  {
    const Eigen::Vector3i c = cellOf(points[x]);
    grid.emplace_back(keyOf(c.x(), c.y(), c.z()), x);
  }
  radixSortStable(grid, [](const std::pair<std::uint64_t, std::uint32_t>& g) { return g.first; });
  std::unordered_map<std::uint64_t, std::pair<std::uint32_t, std::uint32_t>> cell_range;  // [begin, end) in grid
  for (std::uint32_t k = 0; k < grid.size(); ++k)
  {
    auto [it, fresh] = cell_range.try_emplace(grid[k].first, k, k + 1);
    if (!fresh)
      it->second.second = k + 1;
  }

  // Each vertex's settled normal (the sum of its settled triangles' vector areas), that sum
  // normalised, and the sum over the piece being settled.
  std::vector<Eigen::Vector3d> settled(n, Eigen::Vector3d::Zero()), settled_unit(n, Eigen::Vector3d::Zero()),
      own(n, Eigen::Vector3d::Zero());
  std::vector<std::uint32_t> verts;
  std::size_t reversed = 0;
  for (std::uint32_t c : rank)
  {
    verts.clear();
    for (std::uint32_t k = first[c]; k < first[c + 1]; ++k)
    {
      const std::uint32_t t = member[k];
      const Eigen::Vector3d nrm = (points[out[t][1]] - points[out[t][0]]).cross(points[out[t][2]] - points[out[t][0]]);
      for (std::uint32_t x : out[t])
      {
        if (own[x].isZero())
          verts.push_back(x);
        own[x] += nrm;
      }
    }
    if (c != 0)
    {
      double vote = 0;
      for (std::uint32_t p : verts)
      {
        if (own[p].isZero())
          continue;
        const Eigen::Vector3d np = own[p].normalized();
        const double r = radiusAt(p);
        forCellsNear(p, [&](std::uint64_t key) {
          const auto cell = cell_range.find(key);
          if (cell == cell_range.end())
            return;
          for (std::uint32_t k = cell->second.first; k < cell->second.second; ++k)
          {
            const std::uint32_t q = grid[k].second;
            if (q == p || settled[q].isZero())
              continue;
            const Eigen::Vector3d d = points[q] - points[p];
            const double dn = d.norm();
            if (dn > r)
              continue;
            const Eigen::Vector3d& nq = settled_unit[q];
            if (std::abs(d.dot(np)) <= 0.5 * dn && std::abs(d.dot(nq)) <= 0.5 * dn)
              vote += np.dot(nq);
          }
        });
      }
      if (vote < 0)
      {
        ++reversed;
        for (std::uint32_t k = first[c]; k < first[c + 1]; ++k)
          std::swap(out[member[k]][1], out[member[k]][2]);
        for (std::uint32_t p : verts)
          own[p] = -own[p];
      }
    }
    for (std::uint32_t p : verts)
    {
      settled[p] += own[p];
      settled_unit[p] = settled[p].normalized();
      own[p].setZero();
    }
  }
  return reversed;
}

}  // namespace

std::vector<char> keepManifold(const std::vector<Triangle>& out, std::size_t n)
{
  std::vector<char> keep(out.size(), 1);
  {
    // Edges: keep the first two triangles in walk order (triangle order), and only if they
    // disagree in direction. The triangles at edge ab (a < b) are those of a's star that hold b,
    // met in triangle order along the star: seen[b] == a once the first is met, with its direction
    // (+1 for a triangle that runs a -> b, -1 for b -> a) and whether the pair is complete.
    const VertexStars stars = vertexStars(n, out);
    std::vector<std::uint32_t> seen(n, kNone);
    std::vector<signed char> first_direction(n, 0);
    std::vector<char> have_pair(n, 0);
    for (std::uint32_t a = 0; a < n; ++a)
      for (std::uint32_t i = stars.offset[a]; i < stars.offset[a + 1]; ++i)
      {
        const std::uint32_t t = stars.star[i];
        const Triangle& tri = out[t];
        const int k = cornerOf(tri, a);
        for (int j = 1; j < 3; ++j)
        {
          const std::uint32_t b = tri[(k + j) % 3];
          if (b <= a)
            continue;
          const signed char direction = j == 1 ? 1 : -1;
          if (seen[b] != a)
          {
            seen[b] = a;
            first_direction[b] = direction;
            have_pair[b] = 0;
          }
          else if (!have_pair[b] && direction == -first_direction[b])
            have_pair[b] = 1;
          else
            keep[t] = 0;
        }
      }
  }
  // Vertex fans: a vertex keeps its largest fan (triangles connected through edges at it). Removing
  // a fan can split a neighbour's star, so the neighbours are looked at again (a work list).
  {
    const VertexStars stars = vertexStars(n, out, &keep);
    const std::vector<std::uint32_t>& off = stars.offset;
    const std::vector<std::uint32_t>& star = stars.star;
    std::deque<std::uint32_t> work;
    std::vector<char> queued(n, 0);
    for (std::uint32_t v = 0; v < n; ++v)
      if (off[v + 1] - off[v] > 1)
      {
        work.push_back(v);
        queued[v] = 1;
      }
    std::vector<std::uint32_t> local, parent, size;
    std::vector<std::uint64_t> stamp(n, 0);
    std::vector<std::uint32_t> at_corner(n, 0);
    std::uint64_t visit = 0;
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
      // Two triangles at v are joined when they share another corner (an edge at v): each corner
      // remembers the first local triangle that had it (at_corner[x], valid while stamp[x] is this
      // visit's number; v may be visited again). A component's root is its smallest local index
      // whatever the order of the unions.
      ++visit;
      for (std::uint32_t i = 0; i < m; ++i)
        for (const std::uint32_t x : out[local[i]])
        {
          if (x == v)
            continue;
          if (stamp[x] != visit)
          {
            stamp[x] = visit;
            at_corner[x] = i;
            continue;
          }
          const std::uint32_t ri = find(i), rj = find(at_corner[x]);
          if (ri != rj)
            parent[std::max(ri, rj)] = std::min(ri, rj);
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

namespace
{

/// A hole whose ear clipping stops at a chord longer than the gap guard with at most this many
/// vertices left keeps the triangles made so far; the rest stays open (MeshFill::closeLoops).
/// Chosen on the closed shapes at 10% and 3% (bench/bench_surface --closed, before Cocone took the
/// ball radii) against 4, 16 and any size: 8 brings the boundary edges under 0.2% on 14 of 20 runs
/// (10 without the rule, 12 with 4,
/// 15 with 16, 16 with any size) with the distance to the reference within Advancing Front's on as
/// many runs as without it (12); 16 and any size zip long cracks along thin parts (the spool's
/// flanges at 3%: 1.22 × and 1.73 × farther from the reference than without the rule).
constexpr std::size_t kNarrowedLoopRest = 8;

/// Twice the vector area of a closed polygon (its Newell vector): Σ p_i × p_(i+1).
Eigen::Vector3d twiceVectorArea(const std::vector<Eigen::Vector3d>& points, const std::vector<std::uint32_t>& loop)
{
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < loop.size(); ++i)
    sum += points[loop[i]].cross(points[loop[(i + 1) % loop.size()]]);
  return sum;
}

/// The longest edge of a closed polygon: its vertices in order, the last joined to the first.
template <typename Loop>
double longestEdge(const std::vector<Eigen::Vector3d>& points, const Loop& loop)
{
  double longest = 0.0;
  for (std::size_t i = 0; i < loop.size(); ++i)
    longest = std::max(longest, (points[loop[i]] - points[loop[(i + 1) % loop.size()]]).norm());
  return longest;
}

}  // namespace

bool isSlit(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& spacing,
            const std::vector<std::uint32_t>& loop)
{
  double longest = 0.0, finest = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < loop.size(); ++i)
  {
    finest = std::min(finest, spacing[loop[i]]);
    for (std::size_t j = i + 1; j < loop.size(); ++j)
      longest = std::max(longest, (points[loop[i]] - points[loop[j]]).norm());
  }
  return 0.5 * twiceVectorArea(points, loop).norm() < 0.5 * finest * longest;
}

namespace
{

/// The kept triangles at each vertex: a flat index of those kept when it is built, and short lists
/// of the triangles added after that.
class VertexTriangles
{
public:
  VertexTriangles(const std::vector<Triangle>& tris, const std::vector<char>& keep, std::size_t n)
    : stars_(vertexStars(n, tris, &keep))
  {
  }

  void add(std::uint32_t t, const Triangle& tri)
  {
    for (const std::uint32_t v : tri)
      added_[v].push_back(t);
  }

  /// Calls f(t) for every triangle t at v that was kept when the index was built or added since;
  /// one removed since is still listed (the caller checks whether it is kept).
  template <class F>
  void forEach(std::uint32_t v, F&& f) const
  {
    for (std::uint32_t k = stars_.offset[v]; k < stars_.offset[v + 1]; ++k)
      f(stars_.star[k]);
    if (const auto it = added_.find(v); it != added_.end())
      for (const std::uint32_t t : it->second)
        f(t);
  }

private:
  VertexStars stars_;
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> added_;
};

/// The loops of a set of hole edges given as next[v] (the hole goes on from v to next[v]), each
/// from its smallest start in index order, of at most max_edges edges. `all_closed` tells whether
/// every walk came back to its start (false when a walk ends at a vertex without a next, meets a
/// loop walked before or grows too long; such walks give no loop).
std::vector<std::vector<std::uint32_t>> followLoops(const std::unordered_map<std::uint32_t, std::uint32_t>& next,
                                                    std::size_t max_edges, bool& all_closed)
{
  std::vector<std::uint32_t> starts;
  starts.reserve(next.size());
  for (const auto& entry : next)
    starts.push_back(entry.first);
  std::sort(starts.begin(), starts.end());
  all_closed = true;
  std::unordered_set<std::uint32_t> visited;
  std::vector<std::vector<std::uint32_t>> loops;
  for (const std::uint32_t s0 : starts)
  {
    if (visited.count(s0))
      continue;
    std::vector<std::uint32_t> loop;
    bool closed = false;
    for (std::uint32_t v = s0; loop.size() <= max_edges;)
    {
      visited.insert(v);
      loop.push_back(v);
      const auto it = next.find(v);
      if (it == next.end())
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
    if (closed && loop.size() >= 3 && loop.size() <= max_edges)
      loops.push_back(std::move(loop));
    else
      all_closed = false;
  }
  return loops;
}

/// The scan's points grouped by the sample standing for each (openTunnels): whether a triangle lies
/// within a distance of the scan, judged at seven of its points (the centroid, the three of
/// barycentric weights (2/3, 1/6, 1/6) and the edges' midpoints) against the scan points of its
/// three samples, and where those are too far, of the samples next to them (sharing a candidate
/// triangle: around a capped bore, the samples on its wall that no mesh triangle holds).
class ScanPoints
{
public:
  /// `spacing`: the samples' local spacing (the nearest sample is looked for within twice its
  /// median when support.sample_of is empty); `cand`: the candidate triangles.
  ScanPoints(const std::vector<Eigen::Vector3d>& samples, const std::vector<double>& spacing, const ScanSupport& support,
             const std::vector<Triangle>& cand)
    : scan_(&support.points), cand_(&cand), cand_stars_(vertexStars(samples.size(), cand))
  {
    const std::size_t n = samples.size(), m = support.points.size();
    std::vector<std::int64_t> nearest;
    if (support.sample_of.empty())
      nearest = nearestSamples(samples, spacing, support.points);
    const std::vector<std::int64_t>& owner = support.sample_of.empty() ? nearest : support.sample_of;
    auto usable = [&](std::size_t i) { return owner[i] >= 0 && support.points[i].allFinite(); };
    offset_.assign(n + 1, 0);
    for (std::size_t i = 0; i < m; ++i)
      if (usable(i))
        ++offset_[static_cast<std::size_t>(owner[i]) + 1];
    for (std::size_t i = 0; i < n; ++i)
      offset_[i + 1] += offset_[i];
    index_.resize(offset_[n]);
    {
      std::vector<std::uint32_t> pos(offset_.begin(), offset_.end() - 1);
      for (std::size_t i = 0; i < m; ++i)
        if (usable(i))
          index_[pos[static_cast<std::size_t>(owner[i])]++] = static_cast<std::uint32_t>(i);
    }
    // Each sample's distance to its nearest scan point (infinite: it has none).
    gap_.assign(n, std::numeric_limits<double>::infinity());
    for (std::size_t v = 0; v < n; ++v)
    {
      const Eigen::Vector3f p = samples[v].cast<float>();
      float best = std::numeric_limits<float>::infinity();
      for (std::uint32_t i = offset_[v]; i < offset_[v + 1]; ++i)
        best = std::min(best, ((*scan_)[index_[i]] - p).squaredNorm());
      if (offset_[v + 1] > offset_[v])
        gap_[v] = std::sqrt(static_cast<double>(best)) * (1.0 + 1e-6) + 1e-12;
    }
  }
  /// The scan points given to some sample.
  std::size_t size() const { return index_.size(); }
  /// Whether each of the seven points of triangle `t` (sample ids, positions `pos`) has a scan
  /// point within r.
  bool covers(const Triangle& t, const std::array<Eigen::Vector3d, 3>& pos, double r) const
  {
    static constexpr double kW[7][3] = {{1.0 / 3, 1.0 / 3, 1.0 / 3}, {2.0 / 3, 1.0 / 6, 1.0 / 6}, {1.0 / 6, 2.0 / 3, 1.0 / 6},
                                        {1.0 / 6, 1.0 / 6, 2.0 / 3}, {0.5, 0.5, 0.0},             {0.0, 0.5, 0.5},
                                        {0.5, 0.0, 0.5}};
    const auto r2 = static_cast<float>(r * r);
    for (const auto& w : kW)
    {
      const Eigen::Vector3d qd = w[0] * pos[0] + w[1] * pos[1] + w[2] * pos[2];
      // Within r of a sample whose nearest scan point is near enough: covered (the triangle
      // inequality), without looking at the points.
      double dist[3];
      for (int k = 0; k < 3; ++k)
        dist[k] = (qd - pos[k]).norm();
      if (dist[0] + gap_[t[0]] <= r || dist[1] + gap_[t[1]] <= r || dist[2] + gap_[t[2]] <= r)
        continue;
      const Eigen::Vector3f q = qd.cast<float>();
      // The nearest sample's points first.
      int order[3] = {0, 1, 2};
      std::sort(order, order + 3, [&](int a, int b) { return dist[a] < dist[b]; });
      if (nearOf(t[order[0]], q, r2) || nearOf(t[order[1]], q, r2) || nearOf(t[order[2]], q, r2))
        continue;
      // The samples sharing a candidate triangle with one of t's (t's own among them again).
      bool found = false;
      for (int k = 0; k < 3 && !found; ++k)
        for (std::uint32_t i = cand_stars_.offset[t[k]]; i < cand_stars_.offset[t[k] + 1] && !found; ++i)
          for (const std::uint32_t w : (*cand_)[cand_stars_.star[i]])
            if (w != t[k] && nearOf(w, q, r2))
            {
              found = true;
              break;
            }
      if (!found)
        return false;
    }
    return true;
  }

private:
  /// A scan point of sample s within sqrt(r2) of q.
  bool nearOf(std::size_t s, const Eigen::Vector3f& q, float r2) const
  {
    for (std::uint32_t i = offset_[s]; i < offset_[s + 1]; ++i)
      if (((*scan_)[index_[i]] - q).squaredNorm() <= r2)
        return true;
    return false;
  }

  /// Each scan point's nearest sample within twice the samples' median spacing (−1: none).
  static std::vector<std::int64_t> nearestSamples(const std::vector<Eigen::Vector3d>& samples,
                                                  const std::vector<double>& spacing,
                                                  const std::vector<Eigen::Vector3f>& scan)
  {
    std::vector<std::int64_t> owner(scan.size(), -1);
    std::vector<double> positive;
    for (const double s : spacing)
      if (s > 0.0)
        positive.push_back(s);
    if (positive.empty())
      return owner;
    const auto mid = positive.begin() + static_cast<std::ptrdiff_t>(positive.size() / 2);
    std::nth_element(positive.begin(), mid, positive.end());
    const double side = 2.0 * *mid;
    PointGrid grid(side);
    for (std::size_t i = 0; i < samples.size(); ++i)
      grid.insert(samples[i], static_cast<std::int64_t>(i));
    const auto m = static_cast<std::ptrdiff_t>(scan.size());
#pragma omp parallel for schedule(dynamic, 4096)
    for (std::ptrdiff_t i = 0; i < m; ++i)
    {
      const Eigen::Vector3f& p = scan[static_cast<std::size_t>(i)];
      if (p.allFinite())
        owner[static_cast<std::size_t>(i)] = grid.nearest(p.cast<double>(), side);
    }
    return owner;
  }

  const std::vector<Eigen::Vector3f>* scan_;  // the scan's points
  std::vector<std::uint32_t> offset_;         // per sample, its scan points' start in index_
  std::vector<std::uint32_t> index_;          // the scan points' indices, grouped by sample
  std::vector<double> gap_;                   // per sample, the distance to its nearest scan point
  const std::vector<Triangle>* cand_;         // the candidate triangles
  VertexStars cand_stars_;                    // per sample, its candidate triangles
};

/// Step 7, third part: triangles added to the kept mesh, with the use of every edge tracked.
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
            const EdgeUse* u = use.find(edgeKey(tri[k], tri[(k + 1) % 3]));
            if (!u || u->count == 0)
              continue;
            if (u->count == 1 && u->from == tri[(k + 1) % 3])
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

  /// Holes (boundary loops of at most max_edges edges) are closed by ear clipping (clipLoop); a
  /// loop whose ears would all create an existing edge (or, with the ratio guard, an edge longer
  /// than max_edge_ratio × the local spacing: a gap in the sampling) is left open. With the ratio
  /// guard, a loop the clipping closed but for at most kNarrowedLoopRest vertices keeps the
  /// triangles it made (CoconeStats::narrowed_loops): what stays open is the gap itself, unless
  /// it is a slit (isSlit) or the clipping without the guard closes it with no chord longer than
  /// its own longest edge (the mesh has edges that long there already): then it is closed.
  /// `loops` come from holeLoops. Returns the number of loops closed.
  std::size_t closeLoops(std::vector<std::vector<std::uint32_t>> loops, bool ratio_guard)
  {
    std::size_t closed_loops = 0;
    for (std::vector<std::uint32_t>& loop : loops)
    {
      std::vector<Triangle> added = clipLoop(loop, ratio_guard);
      auto smallRest = [&] { return ratio_guard && loop.size() > 3 && loop.size() <= kNarrowedLoopRest; };
      if (smallRest())
      {
        std::vector<std::uint32_t> rest_loop = loop;
        std::vector<Triangle> rest = clipLoop(rest_loop, false);
        if (isSlit(points_, spacing_, loop) || (rest_loop.size() == 3 && chordsWithinEdges(loop, rest)))
        {
          added.insert(added.end(), rest.begin(), rest.end());
          loop = std::move(rest_loop);
        }
      }
      const bool narrowed = smallRest();
      if (loop.size() != 3 && !narrowed)
        continue;  // nothing of this loop is committed
      if (narrowed)
        ++st_.narrowed_loops;
      else
        added.push_back({loop[0], loop[1], loop[2]});
      for (const Triangle& tri : added)
      {
        commit(tri);
        ++st_.filled_triangles;
      }
      closed_loops += narrowed ? 0 : 1;
    }
    return closed_loops;
  }

  /// The boundary loops of at most max_edges edges, each in the direction a triangle closing it
  /// takes (an existing edge a → b gives the hole edge b → a), in a canonical order. A vertex with
  /// two outgoing hole edges (two openings meeting at it) is ambiguous: loops through it are left
  /// out.
  std::vector<std::vector<std::uint32_t>> holeLoops(std::size_t max_edges) const
  {
    std::unordered_map<std::uint32_t, std::uint32_t> hole_next;
    std::vector<std::uint32_t> ambiguous;
    use_.forEach([&](std::uint64_t key, const EdgeUse& u) {
      if (u.count != 1)
        return;
      const auto lo = static_cast<std::uint32_t>(key >> 32), hi = static_cast<std::uint32_t>(key & 0xffffffffu);
      const std::uint32_t a = u.from, b = (a == lo ? hi : lo);
      if (!hole_next.emplace(b, a).second)
        ambiguous.push_back(b);
    });
    for (const std::uint32_t v : ambiguous)
      hole_next.erase(v);  // a walk reaching it ends there
    bool all_closed = false;
    return followLoops(hole_next, max_edges, all_closed);
  }

  /// A piece cut off from the surface around it by a strip of missing triangles is joined back:
  /// two loops of different pieces that face each other (their vector areas, in the closing
  /// direction, make an angle above 120°, and their centres are closer than the sum of their
  /// radii) are joined by a band of triangles instead of being closed one by one. Every edge of the
  /// band must stay within the gap guard and be new to the mesh; the band is zipped from the
  /// closest pair of vertices, forward along one loop and backward along the other, each step taking
  /// the shorter new edge. Pairs are tried nearest first, and two pieces are joined once: a band
  /// never makes a handle (two loops of one piece, or of pieces already joined, are left to the
  /// ear clipping), so it changes no genus. `loops` come from holeLoops; the joined ones are
  /// taken out. Returns the number of pairs joined.
  std::size_t stitchLoops(std::vector<std::vector<std::uint32_t>>& loops)
  {
    const auto& points = points_;
    struct LoopShape
    {
      Eigen::Vector3d centre, area;
      double radius;
    };
    std::vector<LoopShape> shape;
    shape.reserve(loops.size());
    for (const auto& loop : loops)
    {
      LoopShape ls{Eigen::Vector3d::Zero(), twiceVectorArea(points, loop), 0.0};
      for (const std::uint32_t v : loop)
        ls.centre += points[v];
      ls.centre /= static_cast<double>(loop.size());
      for (std::uint32_t v : loop)
        ls.radius = std::max(ls.radius, (points[v] - ls.centre).norm());
      shape.push_back(ls);
    }
    // Candidate pairs: centres closer than the sum of the radii, so their spans along x overlap;
    // a sweep over the loops by the start of that span finds them without looking at all pairs.
    std::vector<std::uint32_t> by_start(loops.size());
    std::iota(by_start.begin(), by_start.end(), 0u);
    auto start = [&](std::uint32_t l) { return shape[l].centre.x() - shape[l].radius; };
    std::sort(by_start.begin(), by_start.end(), [&](std::uint32_t x, std::uint32_t y) {
      return start(x) < start(y) || (start(x) == start(y) && x < y);
    });
    std::vector<std::tuple<double, std::uint32_t, std::uint32_t>> pairs;
    for (std::size_t u = 0; u < by_start.size(); ++u)
    {
      const std::uint32_t i = by_start[u];
      const double end = shape[i].centre.x() + shape[i].radius;
      for (std::size_t w = u + 1; w < by_start.size() && start(by_start[w]) <= end; ++w)
      {
        const std::uint32_t j = by_start[w];
        const LoopShape &a = shape[i], &b = shape[j];
        const double d = (a.centre - b.centre).norm();
        if (d > a.radius + b.radius || a.area.dot(b.area) > -0.5 * a.area.norm() * b.area.norm())
          continue;
        pairs.emplace_back(d, std::min(i, j), std::max(i, j));
      }
    }
    std::sort(pairs.begin(), pairs.end());
    // The pieces of the mesh as it is (through shared vertices). Loops on one piece start
    // united: joining them would make a handle.
    UnionFind pieces(loops.size());
    {
      UnionFind uf = vertexPieces(points.size(), out_, keep_);
      std::unordered_map<std::uint32_t, std::uint32_t> first_loop_of_piece;
      for (std::uint32_t l = 0; l < loops.size(); ++l)
      {
        const auto [f, fresh] = first_loop_of_piece.emplace(uf.find(loops[l][0]), l);
        if (!fresh)
          pieces.unite(f->second, l);
      }
    }
    std::vector<char> joined(loops.size(), 0);
    std::size_t count = 0;
    for (const auto& [d, i, j] : pairs)
    {
      if (joined[i] || joined[j] || pieces.find(i) == pieces.find(j))
        continue;
      std::vector<Triangle> band;
      if (!zipBand(loops[i], loops[j], band))
        continue;
      for (const Triangle& tri : band)
      {
        out_.push_back(tri);
        keep_.push_back(1);
        addEdges(tri);
        ++st_.stitched_triangles;
      }
      joined[i] = joined[j] = 1;
      pieces.unite(i, j);
      ++count;
    }
    std::size_t kept_loops = 0;
    for (std::size_t l = 0; l < loops.size(); ++l)
      if (!joined[l])
      {
        if (kept_loops != l)
          loops[kept_loops] = std::move(loops[l]);
        ++kept_loops;
      }
    loops.resize(kept_loops);
    return count;
  }

private:
  /// A patch of openTunnels: its triangles, its border in their direction (the direction a
  /// triangle closing the hole it leaves takes), the border's centre, twice its vector area and
  /// its radius (the farthest border vertex from the centre).
  struct TunnelPatch
  {
    std::vector<std::uint32_t> triangles, border;
    Eigen::Vector3d centre, area;
    double radius = 0.0;
  };
  static constexpr std::size_t kTunnelPatchTriangles = 64;  ///< a larger patch is not a cap
  static constexpr std::size_t kTunnelBorder = 40;          ///< nor one with a longer border
  static constexpr double kTunnelRadiusRatio = 3.0;  ///< a pair's larger radius at most this × the other's
  static constexpr double kTunnelAxisCos = 0.7;      ///< the axis within acos(this) (45.6°) of both normals

  std::array<Eigen::Vector3d, 3> triangleAt(std::uint32_t t) const
  {
    return {points_[out_[t][0]], points_[out_[t][1]], points_[out_[t][2]]};
  }

  /// The patches of openTunnels: from each seed (a triangle spanning empty space, in index order)
  /// the triangles reached across edges through triangles with a point farther than
  /// kTunnelPatchRadius × h from the scan; kept when at most kTunnelPatchTriangles and bounded by
  /// one simple loop of at most kTunnelBorder edges.
  std::vector<TunnelPatch> tunnelPatches(const std::vector<char>& empty, const ScanPoints& scan, double h) const
  {
    std::vector<TunnelPatch> patches;
    std::vector<char> taken(out_.size(), 0);
    for (std::uint32_t s = 0; s < out_.size(); ++s)
    {
      if (!empty[s] || taken[s])
        continue;
      TunnelPatch p;
      std::vector<std::uint32_t> stack{s};
      taken[s] = 1;
      while (!stack.empty() && p.triangles.size() <= kTunnelPatchTriangles)
      {
        const std::uint32_t t = stack.back();
        stack.pop_back();
        p.triangles.push_back(t);
        for (int k = 0; k < 3; ++k)
          for (const std::uint32_t u : trianglesAt(out_[t][k], out_[t][(k + 1) % 3]))
            if (!taken[u] && (empty[u] || !scan.covers(out_[u], triangleAt(u), kTunnelPatchRadius * h)))
            {
              taken[u] = 1;
              stack.push_back(u);
            }
      }
      if (p.triangles.size() > kTunnelPatchTriangles || !patchBorder(p))
        continue;
      p.centre = Eigen::Vector3d::Zero();
      for (const std::uint32_t v : p.border)
        p.centre += points_[v];
      p.centre /= static_cast<double>(p.border.size());
      for (const std::uint32_t v : p.border)
        p.radius = std::max(p.radius, (points_[v] - p.centre).norm());
      p.area = twiceVectorArea(points_, p.border);
      patches.push_back(std::move(p));
    }
    return patches;
  }

  /// The border of a patch: its edges no other of its triangles holds, in their direction, as one
  /// simple loop of at most kTunnelBorder edges; false when they make none.
  bool patchBorder(TunnelPatch& p) const
  {
    std::vector<std::pair<std::uint32_t, std::uint32_t>> edges;  // a → b
    for (const std::uint32_t t : p.triangles)
      for (int k = 0; k < 3; ++k)
      {
        const std::uint32_t a = out_[t][k], b = out_[t][(k + 1) % 3];
        bool inner = false;
        for (const std::uint32_t u : trianglesAt(a, b))
          inner = inner || (u != t && std::find(p.triangles.begin(), p.triangles.end(), u) != p.triangles.end());
        if (!inner)
          edges.emplace_back(a, b);
      }
    if (edges.size() < 3 || edges.size() > kTunnelBorder)
      return false;
    std::sort(edges.begin(), edges.end());
    for (std::size_t k = 1; k < edges.size(); ++k)
      if (edges[k].first == edges[k - 1].first)
        return false;  // two border edges leave one vertex: not a simple loop
    auto next = [&](std::uint32_t v) -> std::optional<std::uint32_t> {
      const auto it = std::lower_bound(edges.begin(), edges.end(), std::make_pair(v, std::uint32_t{0}));
      if (it == edges.end() || it->first != v)
        return std::nullopt;
      return it->second;
    };
    p.border.clear();
    std::uint32_t v = edges.front().first;
    do
    {
      p.border.push_back(v);
      const std::optional<std::uint32_t> w = next(v);
      if (!w || p.border.size() > edges.size())
        return false;
      v = *w;
    } while (v != p.border.front());
    return p.border.size() == edges.size();
  }

  static bool sharesVertex(const std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b)
  {
    for (const std::uint32_t x : a)
      if (std::find(b.begin(), b.end(), x) != b.end())
        return true;
    return false;
  }

  /// The band between borders a and b (each in its patch's direction, which the band's triangles
  /// take at a's edges and reverse at b's: a forward, b backward) of least total squared chord
  /// length among those whose triangles lie within `radius` of the scan, whose chords are new to
  /// the mesh and whose every edge ends between two triangles; dynamic programming over the chord
  /// (a[i], b[j]) for each start on b. False, and `band` untouched, when there is none.
  bool bandOnScan(const std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b, const ScanPoints& scan,
                  double radius, std::vector<Triangle>& band) const
  {
    const std::size_t n = a.size(), m = b.size();
    const double inf = std::numeric_limits<double>::infinity();
    double best = inf;
    std::vector<double> cost((n + 1) * (m + 1));
    std::vector<char> from((n + 1) * (m + 1));
    auto at = [&](std::size_t i, std::size_t j) { return i * (m + 1) + j; };
    for (std::size_t j0 = 0; j0 < m; ++j0)
    {
      auto A = [&](std::size_t i) { return a[i % n]; };
      auto B = [&](std::size_t j) { return b[(j0 + m - j % m) % m]; };
      auto chord = [&](std::size_t i, std::size_t j) {
        return use_.contains(edgeKey(A(i), B(j))) ? inf : (points_[A(i)] - points_[B(j)]).squaredNorm();
      };
      auto onScan = [&](std::uint32_t x, std::uint32_t y, std::uint32_t z) {
        return scan.covers({x, y, z}, {points_[x], points_[y], points_[z]}, radius);
      };
      std::fill(cost.begin(), cost.end(), inf);
      cost[at(0, 0)] = chord(0, 0);
      for (std::size_t i = 0; i <= n; ++i)
        for (std::size_t j = 0; j <= m; ++j)
        {
          if (i + j == 0)
            continue;
          const double c = i == n && j == m ? 0.0 : chord(i, j);  // (n, m) is the first chord again
          if (c == inf)
            continue;
          if (i > 0 && cost[at(i - 1, j)] < inf && onScan(A(i - 1), A(i), B(j)))
          {
            cost[at(i, j)] = cost[at(i - 1, j)] + c;
            from[at(i, j)] = 1;
          }
          if (j > 0 && cost[at(i, j - 1)] + c < cost[at(i, j)] && onScan(B(j), B(j - 1), A(i)))
          {
            cost[at(i, j)] = cost[at(i, j - 1)] + c;
            from[at(i, j)] = 2;
          }
        }
      if (!(cost[at(n, m)] < best))
        continue;
      std::vector<Triangle> zipped;
      for (std::size_t i = n, j = m; i + j > 0;)
      {
        if (from[at(i, j)] == 1)
        {
          zipped.push_back({A(i - 1), A(i), B(j)});
          --i;
        }
        else
        {
          zipped.push_back({B(j), B(j - 1), A(i)});
          --j;
        }
      }
      // Every edge between two triangles: a chord met twice (one border fanned from a single
      // vertex of the other) would end with more.
      std::vector<std::uint64_t> keys;
      for (const Triangle& t : zipped)
        for (int k = 0; k < 3; ++k)
          keys.push_back(edgeKey(t[k], t[(k + 1) % 3]));
      std::sort(keys.begin(), keys.end());
      bool manifold = true;
      for (std::size_t k = 0; k < keys.size() && manifold;)
      {
        std::size_t e = k;
        while (e < keys.size() && keys[e] == keys[k])
          ++e;
        const EdgeUse* u = use_.find(keys[k]);
        manifold = static_cast<int>(e - k) + (u ? u->count : 0) == 2;
        k = e;
      }
      if (manifold)
      {
        best = cost[at(n, m)];
        band = std::move(zipped);
      }
    }
    return best < inf;
  }

  /// The band between loops a and b (both in the closing direction, turning opposite ways): false,
  /// and nothing made, when an edge it needs exists already or is longer than the gap guard allows.
  bool zipBand(const std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b,
               std::vector<Triangle>& band) const
  {
    const auto& points = points_;
    const std::size_t n = a.size(), m = b.size();
    std::size_t i0 = 0, j0 = 0;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < n; ++i)
      for (std::size_t j = 0; j < m; ++j)
      {
        const double d = (points[a[i]] - points[b[j]]).squaredNorm();
        if (d < best)
        {
          best = d;
          i0 = i;
          j0 = j;
        }
      }
    auto A = [&](std::size_t i) { return a[(i0 + i) % n]; };
    auto B = [&](std::size_t j) { return b[(j0 + m - j % m) % m]; };  // backward along b
    const double guard = params_.max_edge_ratio;
    std::unordered_set<std::uint64_t> chords;
    auto chordOk = [&](std::uint32_t x, std::uint32_t y) {
      const std::uint64_t key = edgeKey(x, y);
      if (use_.contains(key) || chords.count(key))
        return false;
      if (guard > 0)
      {
        const double local = std::max(spacing_[x], spacing_[y]);
        if ((points[x] - points[y]).squaredNorm() > guard * guard * local * local)
          return false;
      }
      return true;
    };
    if (!chordOk(A(0), B(0)))
      return false;
    chords.insert(edgeKey(A(0), B(0)));
    std::size_t i = 0, j = 0;
    while (i < n || j < m)
    {
      bool advance_a;
      if (i == n)
        advance_a = false;
      else if (j == m)
        advance_a = true;
      else
        advance_a = (points[A(i + 1)] - points[B(j)]).squaredNorm() <= (points[A(i)] - points[B(j + 1)]).squaredNorm();
      const std::uint32_t x = advance_a ? A(i + 1) : A(i), y = advance_a ? B(j) : B(j + 1);
      const bool last = (advance_a ? i + 1 == n && j == m : i == n && j + 1 == m);
      if (!last && !chordOk(x, y))
        return false;
      chords.insert(edgeKey(x, y));
      if (advance_a)
      {
        band.push_back({A(i), A(i + 1), B(j)});
        ++i;
      }
      else
      {
        band.push_back({B(j + 1), B(j), A(i)});
        ++j;
      }
    }
    return true;
  }

public:
  /// Tunnels the walk capped (CoconeParameters::open_tunnels, kTunnelEmptyRadius): pairs of facing
  /// patches that span empty space replaced by a band between their borders that lies on the scan.
  /// Returns the pairs replaced.
  std::size_t openTunnels(const ScanSupport& support, const std::vector<Triangle>& cand)
  {
    const auto& points = points_;
    double area = 0.0;
    for (std::uint32_t t = 0; t < out_.size(); ++t)
      if (keep_[t])
        area += 0.5 * (points[out_[t][1]] - points[out_[t][0]]).cross(points[out_[t][2]] - points[out_[t][0]]).norm();
    if (support.empty() || !(area > 0.0))
      return 0;
    const ScanPoints scan(points, spacing_, support, cand);
    if (scan.size() == 0)
      return 0;
    const double h = std::sqrt(area / static_cast<double>(scan.size()));  // the scan's spacing
    // Seeds: triangles spanning empty space (in parallel; a flag per triangle).
    std::vector<char> empty(out_.size(), 0);
    const auto n_out = static_cast<std::ptrdiff_t>(out_.size());
#pragma omp parallel for schedule(static)
    for (std::ptrdiff_t t = 0; t < n_out; ++t)
      if (keep_[static_cast<std::size_t>(t)])
        empty[static_cast<std::size_t>(t)] =
            !scan.covers(out_[static_cast<std::size_t>(t)], triangleAt(static_cast<std::uint32_t>(t)), kTunnelEmptyRadius * h);
    if (std::count(empty.begin(), empty.end(), 1) < 2)
      return 0;
    at_.emplace(out_, keep_, points.size());
    std::vector<TunnelPatch> patches = tunnelPatches(empty, scan, h);
    // Pairs, nearest first: patches of like size (radii within kTunnelRadiusRatio), near each other,
    // the line between their centres within 45° of both normals, running inwards from each (a
    // bore's two caps, whose tube runs along their axis).
    std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;
    for (std::size_t i = 0; i < patches.size(); ++i)
      for (std::size_t j = i + 1; j < patches.size(); ++j)
      {
        const TunnelPatch &a = patches[i], &b = patches[j];
        const Eigen::Vector3d axis = b.centre - a.centre;
        const double d = axis.norm();
        if (d > 2.0 * (a.radius + b.radius) ||
            std::max(a.radius, b.radius) > kTunnelRadiusRatio * std::min(a.radius, b.radius))
          continue;
        if (axis.dot(a.area) <= -kTunnelAxisCos * d * a.area.norm() && axis.dot(b.area) >= kTunnelAxisCos * d * b.area.norm())
          pairs.emplace_back(d, i, j);
      }
    std::sort(pairs.begin(), pairs.end());
    std::vector<char> used(patches.size(), 0);
    std::size_t opened = 0;
    for (const auto& [d, i, j] : pairs)
    {
      if (used[i] || used[j] || sharesVertex(patches[i].border, patches[j].border))
        continue;
      for (const std::size_t p : {i, j})
        for (const std::uint32_t t : patches[p].triangles)
        {
          keep_[t] = 0;
          removeEdges(out_[t]);
        }
      std::vector<Triangle> band;
      if (!bandOnScan(patches[i].border, patches[j].border, scan, kTunnelBandRadius * h, band))
      {
        for (const std::size_t p : {i, j})
          for (const std::uint32_t t : patches[p].triangles)
          {
            keep_[t] = 1;
            addEdges(out_[t]);
          }
        continue;
      }
      for (const Triangle& tri : band)
      {
        out_.push_back(tri);
        keep_.push_back(1);
        addEdges(tri);
        at_->add(static_cast<std::uint32_t>(out_.size() - 1), tri);
      }
      st_.tunnel_triangles += band.size();
      used[i] = used[j] = 1;
      ++opened;
    }
    at_.reset();
    return opened;
  }

  /// Small handles the walk made are cut out (CoconeStats::removed_handles): a cycle of three mesh
  /// edges that is no triangle of the mesh and does not separate it (the triangles on its two sides
  /// are joined around it, found by a search from both sides within kHandleSearch triangles) runs
  /// around a handle. The triangles at its three vertices (then, if that fails, at their
  /// neighbours too) are removed and the holes this opens closed by the ear clipping of closeLoops,
  /// gap guard included; the change is kept when every hole closes whole and the Euler
  /// characteristic rose by at least 2 (a handle gone), and undone otherwise. Such cycles run
  /// around handles a triangle or two wide, where the walk joined two sheets at a sharp edge or a
  /// corner; a tunnel of the surface sampled by more points around has none. A cycle whose edges
  /// are well below the sample spacing at its vertices runs around a thin part of the object
  /// sampled by three points around (kThinPartGirth): it is left as it is. Returns the handles
  /// removed.
  std::size_t removeSmallHandles()
  {
    const std::size_t n = points_.size();
    at_.emplace(out_, keep_, n);
    // The candidate cycles a < b < c, in index order: c a common neighbour of the edge ab.
    std::vector<std::uint32_t> offset(n + 1, 0), nbrs;
    std::vector<std::uint32_t> mark(n, kNone);  // mark[x] == v: x is listed as v's neighbour
    for (std::uint32_t v = 0; v < n; ++v)
    {
      at_->forEach(v, [&](std::uint32_t t) {
        for (const std::uint32_t x : out_[t])
          if (x != v && mark[x] != v)
          {
            mark[x] = v;
            nbrs.push_back(x);
          }
      });
      offset[v + 1] = static_cast<std::uint32_t>(nbrs.size());
    }
    std::vector<Triangle> cycles;
    std::fill(mark.begin(), mark.end(), kNone);  // mark[c] == a: c is a neighbour of a
    for (std::uint32_t a = 0; a < n; ++a)
    {
      for (std::uint32_t k = offset[a]; k < offset[a + 1]; ++k)
        mark[nbrs[k]] = a;
      for (std::uint32_t k = offset[a]; k < offset[a + 1]; ++k)
      {
        const std::uint32_t b = nbrs[k];
        if (b <= a)
          continue;
        std::size_t common = 0;  // two for an edge inside the mesh, unless a cycle runs through it
        for (std::uint32_t j = offset[b]; j < offset[b + 1]; ++j)
          common += mark[nbrs[j]] == a;
        if (common <= 2)
          continue;
        for (std::uint32_t j = offset[b]; j < offset[b + 1]; ++j)
        {
          const std::uint32_t c = nbrs[j];
          if (c > b && mark[c] == a && !isFace(a, b, c))
            cycles.push_back({a, b, c});
        }
      }
    }
    std::sort(cycles.begin(), cycles.end());
    std::size_t removed = 0;
    for (const Triangle& cyc : cycles)
    {
      if (aroundThinPart(cyc))
        continue;  // a thin part of the object, not a handle the walk made
      if (!aroundHandle(cyc))
        continue;  // gone with an earlier handle, or separating
      for (int rings = 1; rings <= 2; ++rings)
        if (cutHandle(cyc, rings))
        {
          ++removed;
          break;
        }
    }
    at_.reset();
    return removed;
  }

private:
  /// Triangles explored from both sides of a cycle before it is judged not to run around a small
  /// handle (removeSmallHandles).
  static constexpr std::size_t kHandleSearch = 20000;

  void commit(const Triangle& tri)
  {
    out_.push_back(tri);
    keep_.push_back(1);
    addEdges(tri);
    if (at_)
      at_->add(static_cast<std::uint32_t>(out_.size() - 1), tri);
  }

  /// The kept triangles at edge (x, y) (at_ must be there).
  std::vector<std::uint32_t> trianglesAt(std::uint32_t x, std::uint32_t y) const
  {
    std::vector<std::uint32_t> at;
    at_->forEach(x, [&](std::uint32_t t) {
      if (keep_[t] && holds(out_[t], y))
        at.push_back(t);
    });
    return at;
  }

  bool isFace(std::uint32_t a, std::uint32_t b, std::uint32_t c) const
  {
    bool face = false;
    at_->forEach(a, [&](std::uint32_t t) {
      const Triangle& tri = out_[t];
      face = face || (keep_[t] && std::count(tri.begin(), tri.end(), b) == 1 && std::count(tri.begin(), tri.end(), c) == 1);
    });
    return face;
  }

  /// Whether some kept triangle holds v.
  bool inMesh(std::uint32_t v) const
  {
    bool kept = false;
    at_->forEach(v, [&](std::uint32_t t) { kept = kept || keep_[t] != 0; });
    return kept;
  }

  /// Whether the cycle of edges ab, bc, ca is shorter than a sampling of the surface around it
  /// would make it (kThinPartGirth).
  bool aroundThinPart(const Triangle& cyc) const
  {
    const double finest = std::min({spacing_[cyc[0]], spacing_[cyc[1]], spacing_[cyc[2]]});
    return longestEdge(points_, cyc) < kThinPartGirth * finest;
  }

  /// Whether no chord (prev - next) of the triangles clipped from `loop` is longer than the
  /// loop's longest edge.
  bool chordsWithinEdges(const std::vector<std::uint32_t>& loop, const std::vector<Triangle>& clipped) const
  {
    const double longest = longestEdge(points_, loop);
    return std::all_of(clipped.begin(), clipped.end(),
                       [&](const Triangle& t) { return (points_[t[0]] - points_[t[2]]).norm() <= longest; });
  }

  /// Whether the cycle of edges ab, bc, ca is there, no triangle, and does not separate the mesh:
  /// the two triangles at ab meet across edges other than the cycle's within kHandleSearch
  /// triangles, searched from both at once (a separating cycle's smaller side is used up first).
  bool aroundHandle(const Triangle& cyc) const
  {
    const auto [a, b, c] = cyc;
    for (int k = 0; k < 3; ++k)
    {
      const EdgeUse* u = use_.find(edgeKey(cyc[k], cyc[(k + 1) % 3]));
      if (!u || u->count != 2)
        return false;
    }
    if (isFace(a, b, c))
      return false;
    const std::vector<std::uint32_t> start = trianglesAt(a, b);
    if (start.size() != 2)
      return false;
    const std::uint64_t cut[3] = {edgeKey(a, b), edgeKey(b, c), edgeKey(c, a)};
    // side_[t]: 0 or 1 when triangle t was reached from start[side], -1 otherwise (reset on the
    // way out).
    if (side_.size() < out_.size())
      side_.resize(out_.size(), -1);
    std::vector<std::uint32_t> queue[2];
    std::size_t head[2] = {0, 0};
    for (int s = 0; s < 2; ++s)
    {
      side_[start[s]] = static_cast<std::int8_t>(s);
      queue[s].push_back(start[s]);
    }
    bool met = false;
    std::size_t explored = 0;
    while (!met && head[0] < queue[0].size() && head[1] < queue[1].size() && explored < kHandleSearch)
      for (int s = 0; s < 2 && !met; ++s)
      {
        const std::uint32_t t = queue[s][head[s]++];
        ++explored;
        for (int k = 0; k < 3 && !met; ++k)
        {
          const std::uint32_t x = out_[t][k], y = out_[t][(k + 1) % 3];
          const std::uint64_t key = edgeKey(x, y);
          if (key == cut[0] || key == cut[1] || key == cut[2])
            continue;
          at_->forEach(x, [&](std::uint32_t u) {
            if (met || !keep_[u] || !holds(out_[u], y))
              return;
            if (side_[u] < 0)
            {
              side_[u] = static_cast<std::int8_t>(s);
              queue[s].push_back(u);
            }
            else if (side_[u] != s)
              met = true;
          });
        }
      }
    for (int s = 0; s < 2; ++s)
      for (const std::uint32_t t : queue[s])
        side_[t] = -1;
    return met;
  }

  /// removeSmallHandles' change at one cycle: the kept triangles within `rings` rings of its
  /// vertices removed, the holes closed; kept when every hole closed and χ rose by at least 2.
  bool cutHandle(const Triangle& cyc, int rings)
  {
    std::vector<std::uint32_t> verts(cyc.begin(), cyc.end()), region;
    for (int r = 0; r < rings; ++r)
    {
      region.clear();
      for (const std::uint32_t v : verts)
        at_->forEach(v, [&](std::uint32_t t) {
          if (keep_[t])
            region.push_back(t);
        });
      std::sort(region.begin(), region.end());
      region.erase(std::unique(region.begin(), region.end()), region.end());
      if (r + 1 < rings)
      {
        for (const std::uint32_t t : region)
          verts.insert(verts.end(), out_[t].begin(), out_[t].end());
        std::sort(verts.begin(), verts.end());
        verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
      }
    }
    // χ of what the change touches, before and after: its triangles, their edges and vertices.
    std::vector<std::uint64_t> edges;
    std::vector<std::uint32_t> vertices;
    for (const std::uint32_t t : region)
      for (int k = 0; k < 3; ++k)
      {
        edges.push_back(edgeKey(out_[t][k], out_[t][(k + 1) % 3]));
        vertices.push_back(out_[t][k]);
      }
    auto touchedChi = [&](const std::vector<Triangle>& added) {
      std::vector<std::uint64_t> e = edges;
      for (const Triangle& tri : added)
        for (int k = 0; k < 3; ++k)
          e.push_back(edgeKey(tri[k], tri[(k + 1) % 3]));
      std::sort(e.begin(), e.end());
      e.erase(std::unique(e.begin(), e.end()), e.end());
      std::vector<std::uint32_t> v = vertices;
      std::sort(v.begin(), v.end());
      v.erase(std::unique(v.begin(), v.end()), v.end());
      long chi = 0;
      for (const std::uint64_t key : e)
        if (const EdgeUse* u = use_.find(key); u && u->count > 0)
          --chi;
      for (const std::uint32_t x : v)
        chi += inMesh(x) ? 1 : 0;
      return chi;
    };
    const long before = touchedChi({}) + static_cast<long>(region.size());
    for (const std::uint32_t t : region)
    {
      keep_[t] = 0;
      removeEdges(out_[t]);
    }
    // The holes: hole edges b -> a of the edges a -> b the removal left with one triangle; a
    // vertex with two of them (a pinch) or a hole through an edge that was open before fails.
    std::unordered_map<std::uint32_t, std::uint32_t> hole_next;
    bool ok = true;
    std::vector<std::uint64_t> sorted_edges = edges;
    std::sort(sorted_edges.begin(), sorted_edges.end());
    sorted_edges.erase(std::unique(sorted_edges.begin(), sorted_edges.end()), sorted_edges.end());
    for (const std::uint64_t key : sorted_edges)
    {
      const EdgeUse* u = use_.find(key);
      if (!u || u->count != 1)
        continue;
      const auto lo = static_cast<std::uint32_t>(key >> 32), hi = static_cast<std::uint32_t>(key & 0xffffffffu);
      const std::uint32_t from = u->from, to = from == lo ? hi : lo;
      ok = ok && hole_next.emplace(to, from).second;
    }
    bool all_closed = false;  // false: a hole goes on along an edge that was open before
    std::vector<std::vector<std::uint32_t>> loops =
        followLoops(hole_next, std::numeric_limits<std::size_t>::max() - 1, all_closed);
    ok = ok && all_closed;
    std::vector<Triangle> added;
    for (std::vector<std::uint32_t>& loop : loops)
    {
      if (!ok)
        break;
      std::vector<Triangle> clipped = clipLoop(loop, true);
      if (loop.size() != 3)
      {
        ok = false;
        break;
      }
      clipped.push_back({loop[0], loop[1], loop[2]});
      for (const Triangle& tri : clipped)
        addEdges(tri);  // the next hole's chords must not repeat these
      added.insert(added.end(), clipped.begin(), clipped.end());
    }
    for (const Triangle& tri : added)
      removeEdges(tri);
    if (ok)
    {
      const std::size_t first = out_.size();
      for (const Triangle& tri : added)
        commit(tri);
      const long after = touchedChi(added) + static_cast<long>(added.size());
      if (after - before >= 2)
      {
        st_.filled_triangles += added.size();
        return true;
      }
      for (std::size_t t = first; t < out_.size(); ++t)
      {
        keep_[t] = 0;
        removeEdges(out_[t]);
      }
    }
    for (const std::uint32_t t : region)
    {
      keep_[t] = 1;
      addEdges(out_[t]);
    }
    return false;
  }

  /// Ear clipping of one loop until three vertices are left or no ear is allowed: each step clips
  /// the ear (prev, cur, next) whose chord prev-next is shortest, among the convex ones (against
  /// the loop's Newell normal, in the orientation the new triangles take, so that the seal does
  /// not fold over itself) or among all when none is convex, the earliest in the loop of equal
  /// chords; an ear whose chord is an edge of the mesh or of this clipping, or (ratio_guard)
  /// longer than the gap guard, is never clipped. The ears wait in two heaps (convex, any); a
  /// clip changes only the two ears beside it, so a loop of n vertices takes O(n log n).
  /// `loop` is left as what remains, in its order; returns the triangles clipped, in order.
  std::vector<Triangle> clipLoop(std::vector<std::uint32_t>& loop, bool ratio_guard) const
  {
    const auto& points = points_;
    std::vector<Triangle> added;
    const auto n = static_cast<std::uint32_t>(loop.size());
    if (n <= 3)
      return added;
    const Eigen::Vector3d loop_normal = twiceVectorArea(points, loop);
    // The loop as a ring of positions in `loop`; an ear is known by the position of its tip.
    std::vector<std::uint32_t> before(n), after(n), stamp(n, 0);
    for (std::uint32_t i = 0; i < n; ++i)
    {
      before[i] = (i + n - 1) % n;
      after[i] = (i + 1) % n;
    }
    std::vector<char> clipped(n, 0);
    struct Ear
    {
      double chord;  // squared
      std::uint32_t at, stamp;
      bool operator>(const Ear& o) const { return chord > o.chord || (chord == o.chord && at > o.at); }
    };
    using Heap = std::priority_queue<Ear, std::vector<Ear>, std::greater<Ear>>;
    Heap convex, any;
    std::unordered_set<std::uint64_t> chords;
    // (Re)queues the ear at position i; an earlier entry of it goes stale. A chord made later can
    // equal this ear's only when three vertices are left, where the clipping stops.
    auto queueEar = [&](std::uint32_t i) {
      ++stamp[i];
      const std::uint32_t prev = loop[before[i]], cur = loop[i], next = loop[after[i]];
      const std::uint64_t key = edgeKey(prev, next);
      if (use_.contains(key) || chords.count(key))
        return;
      const double len = (points[prev] - points[next]).squaredNorm();
      if (ratio_guard && params_.max_edge_ratio > 0)
      {
        const double local = std::max({spacing_[prev], spacing_[cur], spacing_[next]});
        if (len > params_.max_edge_ratio * params_.max_edge_ratio * local * local)
          return;
      }
      const Ear ear{len, i, stamp[i]};
      if ((points[cur] - points[prev]).cross(points[next] - points[prev]).dot(loop_normal) > 0)
        convex.push(ear);
      any.push(ear);
    };
    auto top = [&](Heap& heap) -> const Ear* {
      while (!heap.empty() && (clipped[heap.top().at] || heap.top().stamp != stamp[heap.top().at]))
        heap.pop();
      return heap.empty() ? nullptr : &heap.top();
    };
    for (std::uint32_t i = 0; i < n; ++i)
      queueEar(i);
    for (std::uint32_t left = n; left > 3; --left)
    {
      const Ear* ear = top(convex);
      if (ear == nullptr)
        ear = top(any);
      if (ear == nullptr)
        break;
      const std::uint32_t i = ear->at, b = before[i], a = after[i];
      added.push_back({loop[b], loop[i], loop[a]});
      chords.insert(edgeKey(loop[b], loop[a]));
      clipped[i] = 1;
      after[b] = a;
      before[a] = b;
      queueEar(b);
      queueEar(a);
    }
    std::size_t kept = 0;
    for (std::uint32_t i = 0; i < n; ++i)
      if (!clipped[i])
        loop[kept++] = loop[i];
    loop.resize(kept);
    return added;
  }

  /// Undoes addEdges; an edge left with one triangle takes that triangle's direction (found
  /// through at_, which removeSmallHandles keeps while it runs).
  void removeEdges(const Triangle& tri)
  {
    for (int k = 0; k < 3; ++k)
    {
      const std::uint32_t x = tri[k], y = tri[(k + 1) % 3];
      const std::uint64_t key = edgeKey(x, y);
      EdgeUse* u = use_.find(key);
      if (--u->count == 0)
      {
        use_.erase(key);
        continue;
      }
      if (u->count != 1)
        continue;
      for (const std::uint32_t t : trianglesAt(x, y))
        for (int j = 0; j < 3; ++j)
          if ((out_[t][j] == x && out_[t][(j + 1) % 3] == y) || (out_[t][j] == y && out_[t][(j + 1) % 3] == x))
            u->from = out_[t][j];
    }
  }

private:
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
  EdgeUseMap use_;
  std::optional<VertexTriangles> at_;  // while removeSmallHandles runs: the triangles at each vertex
  mutable std::vector<std::int8_t> side_;  // aroundHandle's search: the side each triangle was reached from
};

/// The point of triangle abc nearest to p (Ericson, Real-Time Collision Detection, 5.1.5).
Eigen::Vector3d closestOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                  const Eigen::Vector3d& c)
{
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0)
    return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3)
    return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0)
    return a + d1 / (d1 - d3) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6)
    return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0)
    return a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
    return b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

/// A closed piece of at most this share of the largest piece's triangles, every vertex of which
/// lies within kLayerDistance × its local spacing of the largest piece, is a second layer over
/// that surface, not a surface of its own (keepLargeComponents).
constexpr double kLayerShare = 0.01;
constexpr double kLayerDistance = 0.5;
}  // namespace

/// Step 7, last part (cocone_detail.h): small pieces and second layers dropped.
std::vector<Triangle> keepLargeComponents(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& spacing,
                                          const std::vector<Triangle>& out, const std::vector<char>& keep,
                                          const std::vector<std::uint32_t>& side_neighbours,
                                          const CoconeParameters& params, CoconeStats& st)
{
  // The kept triangles, renumbered, and the table of the triangles across their sides (after
  // keepManifold and the filling, at most two triangles share an edge).
  std::vector<Triangle> kept;
  std::vector<std::uint32_t> index(out.size(), kNone);
  for (std::uint32_t t = 0; t < out.size(); ++t)
    if (keep[t])
    {
      index[t] = static_cast<std::uint32_t>(kept.size());
      kept.push_back(out[t]);
    }
  std::vector<std::uint32_t> nbr(3 * kept.size());
  for (std::uint32_t t = 0; t < out.size(); ++t)
    if (index[t] != kNone)
      for (std::uint32_t k = 0; k < 3; ++k)
      {
        const std::uint32_t u = side_neighbours[3 * static_cast<std::size_t>(t) + k];
        nbr[3 * static_cast<std::size_t>(index[t]) + k] = u == kNone ? kNone : index[u];
      }
  UnionFind uf(kept.size());
  for (std::uint32_t t = 0; t < kept.size(); ++t)
    for (std::uint32_t k = 0; k < 3; ++k)
      if (nbr[3 * static_cast<std::size_t>(t) + k] != kNone)
        uf.unite(t, nbr[3 * static_cast<std::size_t>(t) + k]);
  std::vector<std::size_t> size(kept.size(), 0);
  for (std::uint32_t t = 0; t < kept.size(); ++t)
    ++size[uf.find(t)];
  const std::size_t min_size = std::max<std::size_t>(params.min_component_triangles, 1);
  std::vector<char> drop(kept.size(), 0);
  for (std::uint32_t t = 0; t < kept.size(); ++t)
    drop[t] = size[uf.find(t)] < min_size;
  // The largest piece (the first of the largest, in triangle order) and the second layers over it.
  std::uint32_t largest = 0;
  for (std::uint32_t t = 0; t < kept.size(); ++t)
    if (uf.find(t) == t && size[t] > size[largest])
      largest = t;
  std::vector<std::vector<std::uint32_t>> members(kept.size());
  for (std::uint32_t t = 0; t < kept.size(); ++t)
  {
    const std::uint32_t r = uf.find(t);
    if (!drop[t] && r != largest && static_cast<double>(size[r]) <= kLayerShare * static_cast<double>(size[largest]))
      members[r].push_back(t);
  }
  // A piece is closed when each of its edges has two triangles.
  std::vector<char> open(kept.size(), 0);
  for (std::uint32_t t = 0; t < kept.size(); ++t)
    for (std::uint32_t k = 0; k < 3; ++k)
      if (nbr[3 * static_cast<std::size_t>(t) + k] == kNone)
        open[uf.find(t)] = 1;
  // The largest piece's triangles by their lowest x, and the widest of them along x (made when a
  // closed piece is first tested).
  std::vector<std::pair<double, std::uint32_t>> by_low_x;
  double widest_x = 0.0;
  auto largestByLowX = [&] {
    for (std::uint32_t t = 0; t < kept.size(); ++t)
      if (uf.find(t) == largest)
      {
        const Triangle& tri = kept[t];
        const double x0 = std::min({points[tri[0]].x(), points[tri[1]].x(), points[tri[2]].x()});
        const double x1 = std::max({points[tri[0]].x(), points[tri[1]].x(), points[tri[2]].x()});
        by_low_x.emplace_back(x0, t);
        widest_x = std::max(widest_x, x1 - x0);
      }
    // By x (then triangle: the items are in triangle order and the sort is stable), on the
    // double's bits made to order as the numbers do (the same order but for -0 before +0, which
    // the box test below does not mind).
    radixSortStable(by_low_x, [](const std::pair<double, std::uint32_t>& e) {
      std::uint64_t u;
      std::memcpy(&u, &e.first, sizeof u);
      return (u >> 63) != 0 ? ~u : u | (std::uint64_t{1} << 63);
    });
  };
  for (std::uint32_t r = 0; r < kept.size(); ++r)
  {
    if (members[r].empty() || open[r])
      continue;
    // Its vertices, each with the distance it must come within, and their box grown by the largest.
    std::vector<std::pair<std::uint32_t, double>> verts;
    for (const std::uint32_t t : members[r])
      for (const std::uint32_t v : kept[t])
        verts.emplace_back(v, kLayerDistance * spacing[v]);
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    Eigen::Vector3d lo = points[verts[0].first], hi = lo;
    double reach = 0.0;
    for (const auto& [v, d] : verts)
    {
      lo = lo.cwiseMin(points[v]);
      hi = hi.cwiseMax(points[v]);
      reach = std::max(reach, d);
    }
    if (!(reach > 0.0) || !std::isfinite(reach))
      continue;
    lo.array() -= reach;
    hi.array() += reach;
    std::vector<double> nearest(verts.size(), std::numeric_limits<double>::infinity());
    if (by_low_x.empty())
      largestByLowX();
    // The largest piece's triangles whose box meets this one: their lowest x at most hi.x and
    // their highest x at least lo.x, so their lowest x at least lo.x less the widest triangle
    // (twice that: a margin for rounding; the box test below decides).
    auto first = std::lower_bound(by_low_x.begin(), by_low_x.end(), lo.x() - 2 * widest_x,
                                  [](const std::pair<double, std::uint32_t>& e, double x) { return e.first < x; });
    for (; first != by_low_x.end() && first->first <= hi.x(); ++first)
    {
      const Triangle& tri = kept[first->second];
      const Eigen::Vector3d tlo = points[tri[0]].cwiseMin(points[tri[1]]).cwiseMin(points[tri[2]]);
      const Eigen::Vector3d thi = points[tri[0]].cwiseMax(points[tri[1]]).cwiseMax(points[tri[2]]);
      if ((tlo.array() > hi.array()).any() || (thi.array() < lo.array()).any())
        continue;
      for (std::size_t k = 0; k < verts.size(); ++k)
      {
        const Eigen::Vector3d& p = points[verts[k].first];
        nearest[k] = std::min(nearest[k], (closestOnTriangle(p, points[tri[0]], points[tri[1]], points[tri[2]]) - p).norm());
      }
    }
    bool layer = true;
    for (std::size_t k = 0; k < verts.size() && layer; ++k)
      layer = nearest[k] <= verts[k].second;
    if (layer)
    {
      for (const std::uint32_t t : members[r])
        drop[t] = 1;
      ++st.dropped_layers;
    }
  }
  std::vector<Triangle> result;
  for (std::uint32_t t = 0; t < kept.size(); ++t)
  {
    if (drop[t])
      continue;
    st.components += uf.find(t) == t ? 1 : 0;
    result.push_back(kept[t]);
  }
  return result;
}

namespace
{
/// Step 7, last part: the kept mesh smoothed by edge flips. An edge between two kept triangles is
/// flipped when the other diagonal of their quad bends the surface less, measured as the sum of
/// (1 − cos) of the angles between the normals across the five edges the flip changes (the diagonal
/// and the quad's four sides), and the new edge is not in the mesh and within the gap guard
/// (`max_edge_ratio` × the larger spacing of its ends). Each flip lowers that sum over the mesh, so
/// the flips stop. Deterministic (triangle order). Returns the flips made; `nbr` is then the side
/// neighbour table of the result (as sideNeighbours numbers it).
std::size_t flipToBendLess(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& spacing,
                           double guard, std::vector<Triangle>& out, const std::vector<char>& keep,
                           std::vector<std::uint32_t>& nbr)
{
  const auto count = static_cast<std::uint32_t>(out.size());
  auto sideOf = [&](std::uint32_t t, std::uint32_t x, std::uint32_t y) -> std::uint32_t {
    for (std::uint32_t k = 0; k < 3; ++k)
    {
      const std::uint32_t p = out[t][k], q = out[t][(k + 1) % 3];
      if ((p == x && q == y) || (p == y && q == x))
        return k;
    }
    return 3;
  };
  // nbr[3 t + k]: the kept triangle across side k of kept triangle t (from out[t][k] to
  // out[t][k + 1]), kNone on a boundary (or where more than two kept triangles share the edge);
  // kept up to date through the flips.
  nbr = sideNeighbours(out, vertexStars(points.size(), out, &keep));
  auto normal = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    return (points[b] - points[a]).cross(points[c] - points[a]).normalized().eval();
  };
  std::vector<Eigen::Vector3d> tn(count, Eigen::Vector3d::Zero());
  for (std::uint32_t t = 0; t < count; ++t)
    if (keep[t])
      tn[t] = normal(out[t][0], out[t][1], out[t][2]);
  auto across = [&](std::uint32_t t, std::uint32_t x, std::uint32_t y) {
    const std::uint32_t k = sideOf(t, x, y);
    return k < 3 ? nbr[3 * t + k] : kNone;
  };
  auto bend = [&](const Eigen::Vector3d& n, std::uint32_t other) { return other == kNone ? 0.0 : 1 - n.dot(tn[other]); };
  auto at = [&](std::uint32_t t, std::uint32_t v) { return static_cast<std::uint32_t>(cornerOf(out[t], v)); };
  // Whether the edge v-w is in the mesh: some triangle of v's fan, walked from t0 (one of them)
  // across the sides at v both ways, holds w (whatever the triangles' orientation).
  auto hasEdge = [&](std::uint32_t t0, std::uint32_t v, std::uint32_t w) {
    for (std::uint32_t way = 0; way < 2; ++way)
    {
      std::uint32_t t = t0, side = way == 0 ? at(t0, v) : (at(t0, v) + 2) % 3;
      for (std::uint32_t steps = 0; steps < count; ++steps)
      {
        if (holds(out[t], w))
          return true;
        const std::uint32_t next = nbr[3 * t + side];
        if (next == kNone)
          break;
        if (next == t0)
          return false;  // round the whole fan
        const std::uint32_t k = at(next, v), s1 = k, s2 = (k + 2) % 3;
        side = nbr[3 * next + s1] == t ? s2 : s1;
        t = next;
      }
    }
    return false;
  };
  // The edges to examine, each once at a time: as the side of the lower of its two triangles.
  std::deque<std::uint32_t> work;  // sides 3 t + k
  std::vector<char> queued(3 * static_cast<std::size_t>(count), 0);
  auto push = [&](std::uint32_t t, std::uint32_t k) {
    const std::uint32_t u = nbr[3 * t + k];
    if (u == kNone)
      return;
    const std::uint32_t side = u < t ? 3 * u + sideOf(u, out[t][k], out[t][(k + 1) % 3]) : 3 * t + k;
    if (!queued[side])
    {
      queued[side] = 1;
      work.push_back(side);
    }
  };
  for (std::uint32_t t = 0; t < count; ++t)
    for (std::uint32_t k = 0; k < 3; ++k)
      if (nbr[3 * t + k] != kNone && t < nbr[3 * t + k])
        push(t, k);
  std::size_t flips = 0;
  const std::size_t max_flips = 10 * static_cast<std::size_t>(count) + 16;
  while (!work.empty() && flips < max_flips)
  {
    const std::uint32_t side = work.front();
    work.pop_front();
    queued[side] = 0;
    const std::uint32_t t1 = side / 3, k = side % 3, t2 = nbr[side];
    if (t2 == kNone)
      continue;
    // t1 = (a, b, c) runs a → b; t2 = (b, a, d).
    const std::uint32_t a = out[t1][k], b = out[t1][(k + 1) % 3], c = out[t1][(k + 2) % 3];
    const std::uint32_t d = apex(out[t2], a, b);
    if (c == d)
      continue;
    if (guard > 0)
    {
      const double local = std::max(spacing[c], spacing[d]);
      if ((points[c] - points[d]).squaredNorm() > guard * guard * local * local)
        continue;
    }
    const Eigen::Vector3d m1u = (points[a] - points[c]).cross(points[d] - points[c]),
                          m2u = (points[b] - points[d]).cross(points[c] - points[d]);
    if (m1u.squaredNorm() <= 0 || m2u.squaredNorm() <= 0)
      continue;
    const Eigen::Vector3d n1 = tn[t1], n2 = tn[t2], m1 = m1u.normalized(), m2 = m2u.normalized();
    const std::uint32_t nbc = across(t1, b, c), nca = across(t1, c, a);
    const std::uint32_t nad = across(t2, a, d), ndb = across(t2, d, b);
    const double before = bend(n1, nbc) + bend(n1, nca) + bend(n2, nad) + bend(n2, ndb) + (1 - n1.dot(n2));
    const double after = bend(m2, nbc) + bend(m1, nca) + bend(m1, nad) + bend(m2, ndb) + (1 - m1.dot(m2));
    // The new edge must not be in the mesh (tested last: most quads do not bend less the other
    // way).
    if (!(after < before - 1e-12) || hasEdge(t1, c, d))
      continue;
    // t1 = (c, a, d): sides c → a, a → d, d → c; t2 = (d, b, c): sides d → b, b → c, c → d.
    out[t1] = {c, a, d};
    out[t2] = {d, b, c};
    tn[t1] = m1;
    tn[t2] = m2;
    nbr[3 * t1] = nca;
    nbr[3 * t1 + 1] = nad;
    nbr[3 * t1 + 2] = t2;
    nbr[3 * t2] = ndb;
    nbr[3 * t2 + 1] = nbc;
    nbr[3 * t2 + 2] = t1;
    if (nad != kNone)
      nbr[3 * nad + sideOf(nad, a, d)] = t1;
    if (nbc != kNone)
      nbr[3 * nbc + sideOf(nbc, b, c)] = t2;
    ++flips;
    // The quad's four sides. The sides of the triangles across them read t1 or t2 too; queuing
    // them as well gives a stricter optimum for more flips and time (15% more on the 120k-point
    // fandisk scan for the same distances).
    push(t1, 0);
    push(t1, 1);
    push(t2, 0);
    push(t2, 1);
  }
  return flips;
}

}  // namespace

std::vector<Triangle> cleanUp(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& spacing,
                              const CoconeParameters& params, const std::vector<Triangle>& cand,
                              const std::vector<char>& alive, const EdgeIndex& edges, Extraction& walked,
                              const ScanSupport& support, CoconeStats& st)
{
  std::vector<Triangle>& out = walked.out;
  std::vector<char> keep = keepManifold(out, points.size());
  st.reoriented_pieces = orientPieces(points, spacing, out, keep);
  MeshFill fill(points, spacing, params, out, keep, st);
  fill.fillNotches(cand, alive, edges, walked.order);
  if (params.fill_hole_edges >= 3)
  {
    std::vector<std::vector<std::uint32_t>> loops = fill.holeLoops(params.fill_hole_edges);
    st.stitched_loops = fill.stitchLoops(loops);
    fill.closeLoops(std::move(loops), true);
    st.removed_handles = fill.removeSmallHandles();
  }
  if (params.open_tunnels && !support.empty())
    st.opened_tunnels = fill.openTunnels(support, cand);
  if (params.watertight)
    st.sealed_loops = fill.closeLoops(fill.holeLoops(std::numeric_limits<std::size_t>::max() - 1), false);
  std::vector<std::uint32_t> side_neighbours;
  st.flipped_edges = flipToBendLess(points, spacing, params.max_edge_ratio, out, keep, side_neighbours);
  return keepLargeComponents(points, spacing, out, keep, side_neighbours, params, st);
}

}  // namespace detail
}  // namespace surface
}  // namespace pcl_ecs
