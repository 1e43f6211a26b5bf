// point_grid.h (private) — points hashed into cubes of a fixed side, to ask whether one lies
// within a distance (at most the side) of a query: only the 27 cubes around the query's can hold
// it, or which is nearest. The cells live in an open-addressing table, and a query skips the
// neighbour cells whose box lies farther than its radius. The gap bound (stages/gap_fill), the
// deviation bound (stages/surface_deviation) and the feature thinning (stages/feature_thinning)
// use it.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "flat_key_map.h"

namespace pcl_ecs
{

class PointGrid
{
public:
  explicit PointGrid(double side) : side_(side), inv_(1.0 / side) {}

  void insert(const Eigen::Vector3d& p, std::int64_t id = -1)
  {
    const std::array<std::int64_t, 3> c = cellOf(p);
    listFor(key(c[0], c[1], c[2])).push_back({p, id});
  }

  /// True when an inserted point lies within `r` (<= the side) of q.
  bool near(const Eigen::Vector3d& q, double r) const
  {
    const double r2 = r * r;
    bool found = false;
    forEachAround(q, r, [&](const Entry& e) { return found = (e.p - q).squaredNorm() <= r2; });
    return found;
  }
  /// The same within the side.
  bool near(const Eigen::Vector3d& q) const { return near(q, side_); }

  /// The id of the inserted point nearest q within `r` (<= the side; ties: the lower id), or −1.
  std::int64_t nearest(const Eigen::Vector3d& q, double r) const { return closest(q, r).id; }

  /// The squared distance from q to the inserted point nearest it within `r` (<= the side), or
  /// `none` when no point lies within `r`.
  double nearestSquared(const Eigen::Vector3d& q, double r, double none) const
  {
    const Closest c = closest(q, r);
    return c.found ? c.d2 : none;
  }

private:
  struct Entry
  {
    Eigen::Vector3d p;
    std::int64_t id;
  };

  struct Closest
  {
    double d2;
    std::int64_t id;
    bool found;
  };
  /// The inserted point nearest q within `r` (ties: the lower id).
  Closest closest(const Eigen::Vector3d& q, double r) const
  {
    Closest c{r * r, -1, false};
    forEachAround(q, r, [&](const Entry& e) {
      const double d2 = (e.p - q).squaredNorm();
      if (d2 <= c.d2 && (!c.found || d2 < c.d2 || e.id < c.id))
        c = {d2, e.id, true};
      return false;
    });
    return c;
  }

  /// Every entry in the cells around q's that can hold a point within `r` (<= the side) of q:
  /// of the 27 (the query's and its neighbours), those whose box lies within `r` of q, until
  /// `visit` returns true.
  template <typename F>
  void forEachAround(const Eigen::Vector3d& q, double r, F visit) const
  {
    if (lists_.empty())
      return;
    const std::array<std::int64_t, 3> c = cellOf(q);
    // Squared distance from q to the slab of the neighbour below / above along each axis (0 for
    // its own): a lower bound on the distance to any point in that neighbour.
    double below[3], above[3];
    for (int a = 0; a < 3; ++a)
    {
      below[a] = std::max(0.0, q[a] - static_cast<double>(c[a]) * side_);
      above[a] = std::max(0.0, static_cast<double>(c[a] + 1) * side_ - q[a]);
      below[a] *= below[a];
      above[a] *= above[a];
    }
    const double r2 = r * r;
    for (int dx = -1; dx <= 1; ++dx)
    {
      const double gx = dx < 0 ? below[0] : dx > 0 ? above[0] : 0.0;
      if (gx > r2)
        continue;
      for (int dy = -1; dy <= 1; ++dy)
      {
        const double gy = gx + (dy < 0 ? below[1] : dy > 0 ? above[1] : 0.0);
        if (gy > r2)
          continue;
        for (int dz = -1; dz <= 1; ++dz)
        {
          if (gy + (dz < 0 ? below[2] : dz > 0 ? above[2] : 0.0) > r2)
            continue;
          if (const std::vector<Entry>* cell = find(key(c[0] + dx, c[1] + dy, c[2] + dz)))
            for (const Entry& e : *cell)
              if (visit(e))
                return;
        }
      }
    }
  }

  std::array<std::int64_t, 3> cellOf(const Eigen::Vector3d& p) const
  {
    auto f = [&](double x) {
      return static_cast<std::int64_t>(std::max(-1e12, std::min(1e12, std::floor(x * inv_))));
    };
    return {f(p.x()), f(p.y()), f(p.z())};
  }
  /// 21 bits of each cell coordinate (coordinates clamped to ±1e12 cells: cells that share a key
  /// only share a list; the distances decide). Bit 63 stays clear: no key is FlatKeyMap's kEmpty.
  static std::uint64_t key(std::int64_t x, std::int64_t y, std::int64_t z)
  {
    auto u = [](std::int64_t v) { return static_cast<std::uint64_t>(v) & 0x1FFFFFu; };
    return u(x) | (u(y) << 21) | (u(z) << 42);
  }

  const std::vector<Entry>* find(std::uint64_t k) const
  {
    const std::uint32_t* list = cells_.find(k);
    return list ? &lists_[*list] : nullptr;
  }
  std::vector<Entry>& listFor(std::uint64_t k)
  {
    const auto [list, made] = cells_.insert(k);
    if (!made)
      return lists_[*list];
    *list = static_cast<std::uint32_t>(lists_.size());
    return lists_.emplace_back();
  }

  double side_, inv_;
  FlatKeyMap<std::uint32_t> cells_;        // cell key -> its list in lists_
  std::vector<std::vector<Entry>> lists_;  // one per occupied cell
};

}  // namespace pcl_ecs
