// cocone_cleanup.cpp — step 7 of the Cocone reconstruction (cocone.h): an oriented 2-manifold,
// notches and holes closed, loops sealed when asked, small components dropped.
#include "cocone_detail.h"

#include <deque>
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

std::vector<Triangle> cleanUp(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& spacing,
                              const CoconeParameters& params, const std::vector<Triangle>& cand,
                              const std::vector<char>& alive, const EdgeIndex& edges, Extraction& walked,
                              CoconeStats& st)
{
  std::vector<Triangle>& out = walked.out;
  std::vector<char> keep = keepManifold(out, points.size());
  MeshFill fill(points, spacing, params, out, keep, st);
  fill.fillNotches(cand, alive, edges, walked.order);
  if (params.fill_hole_edges >= 3)
    fill.closeLoops(params.fill_hole_edges, true);
  if (params.watertight)
    st.sealed_loops = fill.closeLoops(std::numeric_limits<std::size_t>::max() - 1, false);
  return keepLargeComponents(out, keep, params, st);
}

}  // namespace detail
}  // namespace surface
}  // namespace pcl_ecs
