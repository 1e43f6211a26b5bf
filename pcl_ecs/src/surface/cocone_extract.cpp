// cocone_extract.cpp — steps 5 and 6 of the Cocone reconstruction (cocone.h): pruning and the
// walk that extracts an oriented surface.
#include "cocone_detail.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>

namespace pcl_ecs
{
namespace surface
{
namespace detail
{

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

namespace
{
Eigen::Vector3d triangleNormal(const std::vector<Eigen::Vector3d>& points, const Triangle& tri)
{
  return (points[tri[1]] - points[tri[0]]).cross(points[tri[2]] - points[tri[0]]);
}

/// The live candidate across edge a → b of triangle t (apex c, normal nrm) that turns least from
/// t towards its outside; kNone when the edge has no other live triangle. `turn`, when given, gets
/// its turning angle in (0, 2π] (π: flat, beyond π: a convex edge).
std::uint32_t leastTurning(const std::vector<Eigen::Vector3d>& points, const std::vector<Triangle>& cand,
                           const EdgeIndex& edges, const std::vector<char>& alive, std::uint32_t t, std::uint32_t a,
                           std::uint32_t b, std::uint32_t c, const Eigen::Vector3d& nrm, double* turn = nullptr)
{
  auto range = edges.at(t, a, b);
  if (range.second - range.first < 2)
    return kNone;
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
  if (turn)
    *turn = best;
  return next;
}

/// The walk's queue, best first: triangles (with the orientation they would take) by the bend
/// across the edge that reached them, |π − turn| in steps of π / 32; within a step, first in first
/// out. Pushing below the current step moves back to it (a triangle reached later may lie across
/// a flatter edge than those waiting).
class BendQueue
{
public:
  using Entry = std::pair<std::uint32_t, signed char>;
  void push(double bend, std::uint32_t t, signed char o)
  {
    const int step = std::max(0, std::min(kSteps - 1, static_cast<int>(bend * (kSteps / kPi))));
    steps_[static_cast<std::size_t>(step)].push_back({t, o});
    current_ = std::min(current_, step);
  }
  /// The next entry; false when the queue is empty (it is then ready for another walk).
  bool pop(Entry& e)
  {
    while (current_ < kSteps && head_[static_cast<std::size_t>(current_)] == steps_[static_cast<std::size_t>(current_)].size())
      ++current_;
    if (current_ == kSteps)
    {
      for (int k = 0; k < kSteps; ++k)
      {
        steps_[static_cast<std::size_t>(k)].clear();
        head_[static_cast<std::size_t>(k)] = 0;
      }
      current_ = 0;
      return false;
    }
    e = steps_[static_cast<std::size_t>(current_)][head_[static_cast<std::size_t>(current_)]++];
    return true;
  }

private:
  static constexpr int kSteps = 32;
  std::array<std::vector<Entry>, kSteps> steps_;
  std::array<std::size_t, kSteps> head_{};
  int current_ = 0;
};

/// The seeds of the first piece: at the hull vertex of largest x, then at the one of smallest x,
/// the live triangle most aligned with that vertex's axis (a triangle once); none when no hull
/// vertex has a live triangle.
std::vector<std::uint32_t> hullSeeds(const std::vector<Eigen::Vector3d>& points, const std::vector<Triangle>& cand,
                                     const std::vector<char>& alive, const Poles& poles)
{
  const std::size_t n = points.size();
  const auto& is_hull = poles.is_hull;
  const auto& axis = poles.axis;
  std::vector<std::uint32_t> first_tri(n, kNone);
  for (std::uint32_t t = 0; t < cand.size(); ++t)
    if (alive[t])
      for (std::uint32_t x : cand[t])
        if (first_tri[x] == kNone)
          first_tri[x] = t;
  std::vector<std::uint32_t> seeds;
  for (const double sign : {1.0, -1.0})
  {
    std::uint32_t best_v = kNone;
    for (std::uint32_t v = 0; v < n; ++v)
      if (first_tri[v] != kNone && is_hull[v] && (best_v == kNone || sign * points[v].x() > sign * points[best_v].x()))
        best_v = v;
    if (best_v == kNone)
      return seeds;
    // The triangle at best_v most aligned with its axis.
    std::uint32_t seed = kNone;
    double align = -1;
    for (std::uint32_t t = 0; t < cand.size(); ++t)
    {
      if (!alive[t] || !holds(cand[t], best_v))
        continue;
      const Eigen::Vector3d nrm = triangleNormal(points, cand[t]).normalized();
      const double al = std::abs(nrm.dot(axis[best_v]));
      if (al > align)
      {
        align = al;
        seed = t;
      }
    }
    if (std::find(seeds.begin(), seeds.end(), seed) == seeds.end())
      seeds.push_back(seed);
  }
  return seeds;
}
}  // namespace

/// Step 6: walk the live candidates into oriented pieces, each edge crossed to the neighbour that
/// turns least, best first (the flattest crossing first: BendQueue); seeds: first the hull's
/// two extreme-x vertices, then any unused triangle.
Extraction extractSurface(const std::vector<Eigen::Vector3d>& points, const std::vector<Triangle>& cand,
                          const EdgeIndex& edges, const std::vector<char>& alive, const Poles& poles)
{
  const std::size_t n = points.size();
  const auto& is_hull = poles.is_hull;
  const auto& has_axis = poles.has_axis;
  const auto& axis = poles.axis;
  std::vector<signed char> orient(cand.size(), 0);  // +1: as stored, −1: reversed
  std::vector<std::uint32_t> order;                  // extracted triangles, in walk order
  std::vector<char> vertex_used(n, 0);
  auto oriented = [&](std::uint32_t t) {
    Triangle tri = cand[t];
    if (orient[t] < 0)
      std::swap(tri[1], tri[2]);
    return tri;
  };
  auto normalOf = [&](const Triangle& tri) { return triangleNormal(points, tri); };
  // Best first (BendQueue): orientation spreads across the flattest edges before it crosses a
  // sharp turn, so a sliver or a chord across a thin part that the walk meets early cannot turn
  // the rest of the surface inside out; the surface meets it from all sides first.
  BendQueue queue;
  auto walk = [&](const std::vector<std::pair<std::uint32_t, signed char>>& seeds) {
    for (const auto& [seed, seed_orient] : seeds)
      queue.push(0.0, seed, seed_orient);
    BendQueue::Entry e;
    while (queue.pop(e))
    {
      const auto [t, o] = e;
      if (orient[t] != 0)
        continue;
      orient[t] = o;
      order.push_back(t);
      const Triangle tri = oriented(t);
      const Eigen::Vector3d nrm = normalOf(tri);
      for (int k = 0; k < 3; ++k)
      {
        const std::uint32_t a = tri[k], b = tri[(k + 1) % 3], c = tri[(k + 2) % 3];
        // Every other live triangle at the edge oriented already (the walk came across it from
        // there): whichever turns least, there is nothing to push.
        bool open = false;
        for (auto [it, end] = edges.at(t, a, b); it != end && !open; ++it)
          open = it->second != t && alive[it->second] && orient[it->second] == 0;
        if (!open)
          continue;
        double turn = 0.0;
        const std::uint32_t next = leastTurning(points, cand, edges, alive, t, a, b, c, nrm, &turn);
        if (next == kNone || orient[next] != 0)
          continue;
        // Consistent orientation: next must traverse b → a.
        const Triangle& s = cand[next];
        const bool has_ba = s[(cornerOf(s, b) + 1) % 3] == a;
        queue.push(std::abs(kPi - turn), next, static_cast<signed char>(has_ba ? 1 : -1));
      }
    }
  };

  // Seeds: first the live triangles at the two extreme-x hull vertices, each oriented along its
  // outward axis, walked together (two fronts: where a thin part turns one of them inside out, the
  // other has claimed the far side already); then any live triangle none of whose vertices is
  // used yet.
  {
    auto orientFor = [&](std::uint32_t t) -> signed char {
      const Eigen::Vector3d nrm = normalOf(cand[t]);
      Eigen::Vector3d out = Eigen::Vector3d::Zero();
      for (std::uint32_t x : cand[t])
        if (is_hull[x] && has_axis[x])
          out += axis[x];
      return out.dot(nrm) < 0 ? -1 : 1;
    };
    const std::vector<std::uint32_t> seeds = hullSeeds(points, cand, alive, poles);
    if (!seeds.empty())
    {
      std::vector<std::pair<std::uint32_t, signed char>> oriented_seeds;
      for (const std::uint32_t seed : seeds)
        oriented_seeds.emplace_back(seed, orientFor(seed));
      walk(oriented_seeds);
      for (std::size_t k = 0; k < order.size(); ++k)
        for (std::uint32_t x : cand[order[k]])
          vertex_used[x] = 1;
    }
    for (std::uint32_t t = 0; t < cand.size(); ++t)
    {
      if (!alive[t] || orient[t] != 0)
        continue;
      if (vertex_used[cand[t][0]] || vertex_used[cand[t][1]] || vertex_used[cand[t][2]])
        continue;
      const std::size_t before = order.size();
      walk({{t, orientFor(t)}});
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


}  // namespace detail
}  // namespace surface
}  // namespace pcl_ecs
