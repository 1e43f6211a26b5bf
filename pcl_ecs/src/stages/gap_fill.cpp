#include <pcl_ecs/stages/gap_fill.h>

#include <pcl_ecs/stages/adaptive_tolerance.h>

#include <algorithm>
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

namespace
{
/// farFrom on a grid holding the outputs.
std::vector<std::uint8_t> farFromGrid(const GapGrid& grid, const std::vector<Eigen::Vector3d>& points, int threads)
{
  std::vector<std::uint8_t> far(points.size(), 0);
  const auto count = static_cast<std::ptrdiff_t>(points.size());
#pragma omp parallel for schedule(dynamic, 1024) num_threads(std::max(1, threads))
  for (std::ptrdiff_t c = 0; c < count; ++c)
    far[static_cast<std::size_t>(c)] = grid.near(points[static_cast<std::size_t>(c)]) ? 0 : 1;
  return far;
}
}  // namespace

std::vector<std::uint8_t> farFrom(const std::vector<Eigen::Vector3d>& outputs,
                                  const std::vector<Eigen::Vector3d>& points, double gap, int threads)
{
  if (!(gap > 0.0) || !std::isfinite(gap))
    return std::vector<std::uint8_t>(points.size(), 0);
  GapGrid grid(gap);
  for (const Eigen::Vector3d& p : outputs)
    grid.insert(p);
  return farFromGrid(grid, points, threads);
}

std::vector<std::size_t> closeGaps(const std::vector<Eigen::Vector3d>& outputs,
                                   const std::vector<Eigen::Vector3d>& candidates, double gap, int threads)
{
  std::vector<std::size_t> kept;
  if (!(gap > 0.0) || !std::isfinite(gap) || candidates.empty())
    return kept;
  GapGrid grid(gap);
  for (const Eigen::Vector3d& p : outputs)
    grid.insert(p);
  // Against the outputs alone (read-only grid: in parallel), then greedily in order.
  const std::vector<std::uint8_t> open = farFromGrid(grid, candidates, threads);
  for (std::size_t c = 0; c < candidates.size(); ++c)
  {
    if (!open[c] || (!kept.empty() && grid.near(candidates[c])))
      continue;
    kept.push_back(c);
    grid.insert(candidates[c]);
  }
  return kept;
}

std::vector<Eigen::Vector3d> outputPositions(const CoverInput& in, const CoverOutput& out)
{
  std::vector<Eigen::Vector3d> outputs;
  outputs.reserve(out.balls.size());
  for (std::size_t i = 0; i < in.cloud.size(); ++i)
    if (in.is_feature[i])
      outputs.push_back(in.cloud[i].getVector3fMap().cast<double>());
  for (const CoverBall& b : out.balls)
    outputs.push_back(b.representative);
  return outputs;
}

void addPointBall(const CoverInput& in, const Parameters& params, double error_threshold, std::size_t i,
                  CoverOutput& out)
{
  CoverBall b;
  b.centre = static_cast<int>(i);
  b.tolerance = adaptTolerance(error_threshold, params.adaptive, params.adaptive_factor, in.curvature[i],
                               in.mean_abs_curvature, in.density[i], in.mean_density);
  b.representative = in.cloud[i].getVector3fMap().cast<double>();
  b.used_centre = true;
  b.attribute_source = static_cast<int>(i);
  b.normal = in.normals[i];
  b.replaced = 1;
  --out.balls[static_cast<std::size_t>(out.owner[i])].replaced;
  out.owner[i] = static_cast<int>(out.balls.size());
  out.balls.push_back(b);
}

std::size_t fillGaps(const CoverInput& in, const Parameters& params, double error_threshold, double gap,
                     CoverOutput& out)
{
  if (!(gap > 0.0) || !std::isfinite(gap))
    return 0;
  const std::size_t n = in.cloud.size();
  auto position = [&](std::size_t i) { return Eigen::Vector3d(in.cloud[i].getVector3fMap().cast<double>()); };
  const std::vector<Eigen::Vector3d> outputs = outputPositions(in, out);
  // Candidates, in cloud order: covered points farther than the gap from their own representative
  // (the others are within it of an output point already).
  const double gap2 = gap * gap;
  std::vector<std::size_t> index;
  std::vector<Eigen::Vector3d> candidates;
  for (std::size_t i = 0; i < n; ++i)
  {
    const int o = out.owner[i];
    if (o < 0)
      continue;
    const Eigen::Vector3d p = position(i);
    if ((p - out.balls[static_cast<std::size_t>(o)].representative).squaredNorm() > gap2)
    {
      index.push_back(i);
      candidates.push_back(p);
    }
  }
  const std::vector<std::size_t> kept = closeGaps(outputs, candidates, gap, resolveThreads(params.threads));
  for (const std::size_t c : kept)
    addPointBall(in, params, error_threshold, index[c], out);
  return kept.size();
}

}  // namespace pcl_ecs
