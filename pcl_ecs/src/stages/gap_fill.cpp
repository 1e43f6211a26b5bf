#include <pcl_ecs/stages/gap_fill.h>

#include <pcl_ecs/stages/adaptive_tolerance.h>

#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace pcl_ecs
{

namespace
{
/// Output points hashed into cubes of side `gap`: a point within `gap` of q lies in one of the 27
/// cubes around q's.
class GapGrid
{
public:
  explicit GapGrid(double gap) : inv_(1.0 / gap), gap2_(gap * gap) {}

  void insert(const Eigen::Vector3d& p)
  {
    const Eigen::Vector3i c = cellOf(p);
    cells_[key(c.x(), c.y(), c.z())].push_back(p);
  }

  /// True when some inserted point lies within the gap of q.
  bool near(const Eigen::Vector3d& q) const
  {
    const Eigen::Vector3i c = cellOf(q);
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz)
        {
          const auto it = cells_.find(key(c.x() + dx, c.y() + dy, c.z() + dz));
          if (it == cells_.end())
            continue;
          for (const Eigen::Vector3d& p : it->second)
            if ((p - q).squaredNorm() <= gap2_)
              return true;
        }
    return false;
  }

private:
  Eigen::Vector3i cellOf(const Eigen::Vector3d& p) const
  {
    return (p * inv_).array().floor().cast<int>();
  }
  static std::uint64_t key(int x, int y, int z)
  {
    // 21 bits per axis (the local frame keeps coordinates within ±2^20 cells of any sane gap).
    auto u = [](int v) { return static_cast<std::uint64_t>(static_cast<std::uint32_t>(v) & 0x1FFFFFu); };
    return u(x) | (u(y) << 21) | (u(z) << 42);
  }

  double inv_, gap2_;
  std::unordered_map<std::uint64_t, std::vector<Eigen::Vector3d>> cells_;
};
}  // namespace

std::size_t fillGaps(const CoverInput& in, const Parameters& params, double error_threshold, double gap,
                     CoverOutput& out)
{
  if (!(gap > 0.0) || !std::isfinite(gap))
    return 0;
  const std::size_t n = in.cloud.size();
  auto position = [&](std::size_t i) { return Eigen::Vector3d(in.cloud[i].getVector3fMap().cast<double>()); };
  GapGrid grid(gap);
  for (std::size_t i = 0; i < n; ++i)
    if (in.is_feature[i])
      grid.insert(position(i));
  for (const CoverBall& b : out.balls)
    grid.insert(b.representative);

  // Candidates: covered points farther than the gap from their own representative and from every
  // other output point (read-only grid: in parallel).
  const double gap2 = gap * gap;
  std::vector<std::uint8_t> open(n, 0);
  const int threads = resolveThreads(params.threads);
  const auto count = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel for schedule(dynamic, 4096) num_threads(threads)
  for (std::ptrdiff_t ii = 0; ii < count; ++ii)
  {
    const auto i = static_cast<std::size_t>(ii);
    const int o = out.owner[i];
    if (o < 0)
      continue;
    const Eigen::Vector3d p = position(i);
    if ((p - out.balls[static_cast<std::size_t>(o)].representative).squaredNorm() <= gap2)
      continue;
    open[i] = grid.near(p) ? 0 : 1;
  }

  // Greedy, in cloud order: a point still open becomes an output point.
  std::size_t added = 0;
  for (std::size_t i = 0; i < n; ++i)
  {
    if (!open[i])
      continue;
    const Eigen::Vector3d p = position(i);
    if (added > 0 && grid.near(p))
      continue;
    CoverBall b;
    b.centre = static_cast<int>(i);
    b.tolerance = adaptTolerance(error_threshold, params.adaptive, params.adaptive_factor, in.curvature[i],
                                 in.mean_abs_curvature, in.density[i], in.mean_density);
    b.representative = p;
    b.used_centre = true;
    b.attribute_source = static_cast<int>(i);
    b.normal = in.normals[i];
    b.replaced = 1;
    --out.balls[static_cast<std::size_t>(out.owner[i])].replaced;
    out.owner[i] = static_cast<int>(out.balls.size());
    out.balls.push_back(b);
    grid.insert(p);
    ++added;
  }
  return added;
}

}  // namespace pcl_ecs
