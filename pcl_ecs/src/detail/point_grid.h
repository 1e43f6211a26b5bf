// point_grid.h (private) — points hashed into cubes of a fixed side, to ask whether one lies
// within a distance (at most the side) of a query: only the 27 cubes around the query's can hold
// it, or which is nearest. The gap bound (stages/gap_fill), the deviation bound
// (stages/surface_deviation) and the feature thinning (stages/feature_thinning) use it.
#pragma once

#include <algorithm>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include <Eigen/Core>

namespace pcl_ecs
{

class PointGrid
{
public:
  explicit PointGrid(double side) : side_(side), inv_(1.0 / side) {}

  void insert(const Eigen::Vector3d& p, std::int64_t id = -1) { cells_[key(cellOf(p))].push_back({p, id}); }

  /// True when an inserted point lies within `r` (<= the side) of q.
  bool near(const Eigen::Vector3d& q, double r) const
  {
    const double r2 = r * r;
    bool found = false;
    forEachAround(q, [&](const Entry& e) { return found = (e.p - q).squaredNorm() <= r2; });
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
    forEachAround(q, [&](const Entry& e) {
      const double d2 = (e.p - q).squaredNorm();
      if (d2 <= c.d2 && (!c.found || d2 < c.d2 || e.id < c.id))
        c = {d2, e.id, true};
      return false;
    });
    return c;
  }

  /// Every entry in the 27 cells around q's (only they can lie within the side of q), until
  /// `visit` returns true.
  template <typename F>
  void forEachAround(const Eigen::Vector3d& q, F visit) const
  {
    const Eigen::Vector3d c = cellOf(q);
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz)
        {
          const auto it = cells_.find(key(c + Eigen::Vector3d(dx, dy, dz)));
          if (it != cells_.end())
            for (const Entry& e : it->second)
              if (visit(e))
                return;
        }
  }

  Eigen::Vector3d cellOf(const Eigen::Vector3d& p) const { return (p * inv_).array().floor(); }
  /// 21 bits of each cell coordinate (clamped before the cast: cells that share a key only share
  /// a bucket; the distances decide).
  static std::uint64_t key(const Eigen::Vector3d& cell)
  {
    auto u = [](double x) {
      return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::max(-1e12, std::min(1e12, x)))) & 0x1FFFFFu;
    };
    return u(cell.x()) | (u(cell.y()) << 21) | (u(cell.z()) << 42);
  }

  double side_, inv_;
  std::unordered_map<std::uint64_t, std::vector<Entry>> cells_;
};

}  // namespace pcl_ecs
