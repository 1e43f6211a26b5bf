#include <pcl_ecs/stages/gap_fill.h>

#include <pcl_ecs/stages/adaptive_tolerance.h>

#include "../detail/point_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <queue>
#include <utility>

namespace pcl_ecs
{


namespace
{
/// farFrom on a grid holding the outputs.
std::vector<std::uint8_t> farFromGrid(const PointGrid& grid, const std::vector<Eigen::Vector3d>& points, int threads)
{
  std::vector<std::uint8_t> far(points.size(), 0);
  const auto count = static_cast<std::ptrdiff_t>(points.size());
#pragma omp parallel for schedule(dynamic, 1024) num_threads(std::max(1, threads))
  for (std::ptrdiff_t c = 0; c < count; ++c)
    far[static_cast<std::size_t>(c)] = grid.near(points[static_cast<std::size_t>(c)]) ? 0 : 1;
  return far;
}

/// Greedily, in the order given: the indices whose points lie farther than `gap` from every point
/// kept before them.
template <typename Position>
std::vector<std::size_t> keepApart(const std::vector<std::size_t>& order, Position position, double gap)
{
  PointGrid kept_grid(gap);
  std::vector<std::size_t> kept;
  for (const std::size_t i : order)
  {
    const Eigen::Vector3d p = position(i);
    if (!kept.empty() && kept_grid.near(p))
      continue;
    kept.push_back(i);
    kept_grid.insert(p);
  }
  return kept;
}
}  // namespace

std::vector<std::uint8_t> farFrom(const std::vector<Eigen::Vector3d>& outputs,
                                  const std::vector<Eigen::Vector3d>& points, double gap, int threads)
{
  if (!(gap > 0.0) || !std::isfinite(gap))
    return std::vector<std::uint8_t>(points.size(), 0);
  PointGrid grid(gap);
  for (const Eigen::Vector3d& p : outputs)
    grid.insert(p);
  return farFromGrid(grid, points, threads);
}

std::vector<std::size_t> closeGaps(const std::vector<Eigen::Vector3d>& outputs,
                                   const std::vector<Eigen::Vector3d>& candidates, double gap, int threads)
{
  if (!(gap > 0.0) || !std::isfinite(gap) || candidates.empty())
    return {};
  PointGrid grid(gap);
  for (const Eigen::Vector3d& p : outputs)
    grid.insert(p);
  // Against the outputs alone (read-only grid: in parallel), then greedily in order.
  // The open candidates are far from the outputs: only the kept ones count after that.
  const std::vector<std::uint8_t> far = farFromGrid(grid, candidates, threads);
  std::vector<std::size_t> open;
  for (std::size_t c = 0; c < candidates.size(); ++c)
    if (far[c])
      open.push_back(c);
  return keepApart(open, [&](std::size_t c) { return candidates[c]; }, gap);
}

std::vector<Eigen::Vector3d> outputPositions(const CoverInput& in, const CoverOutput& out)
{
  std::vector<Eigen::Vector3d> outputs;
  outputs.reserve(out.balls.size());
  for (std::size_t i = 0; i < in.cloud.size(); ++i)
    if (in.featureOutput(i))
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
  if (out.owner[i] >= 0)
    --out.balls[static_cast<std::size_t>(out.owner[i])].replaced;
  out.owner[i] = static_cast<int>(out.balls.size());
  out.balls.push_back(b);
}

std::vector<std::size_t> gapOpenPoints(const CoverInput& in, const Parameters& params, const CoverOutput& out,
                                       double gap, const std::vector<std::size_t>* among)
{
  std::vector<std::size_t> open;
  if (!(gap > 0.0) || !std::isfinite(gap))
    return open;
  auto position = [&](std::size_t i) { return Eigen::Vector3d(in.cloud[i].getVector3fMap().cast<double>()); };
  // Candidates, in cloud order: covered points farther than the gap from their own representative,
  // and feature points the thinning left out farther than it from the feature point standing for
  // them (the others are within it of an output point already).
  const double gap2 = gap * gap;
  std::vector<std::size_t> index;
  std::vector<Eigen::Vector3d> candidates;
  auto consider = [&](std::size_t i) {
    const int o = out.owner[i];
    Eigen::Vector3d stood_for_by;
    if (o >= 0)
      stood_for_by = out.balls[static_cast<std::size_t>(o)].representative;
    else if (in.is_feature[i] && !in.featureOutput(i))
      stood_for_by = position(static_cast<std::size_t>((*in.feature_kept_by)[i]));
    else
      return;
    const Eigen::Vector3d p = position(i);
    if ((p - stood_for_by).squaredNorm() > gap2)
    {
      index.push_back(i);
      candidates.push_back(p);
    }
  };
  if (among)
    for (const std::size_t i : *among)
      consider(i);
  else
    for (std::size_t i = 0; i < in.cloud.size(); ++i)
      consider(i);
  if (candidates.empty())
    return open;
  PointGrid grid(gap);
  for (const Eigen::Vector3d& p : outputPositions(in, out))
    grid.insert(p);
  const std::vector<std::uint8_t> far = farFromGrid(grid, candidates, resolveThreads(params.threads));
  for (std::size_t c = 0; c < index.size(); ++c)
    if (far[c])
      open.push_back(index[c]);
  return open;
}

std::size_t fillOpenGaps(const CoverInput& in, const Parameters& params, double error_threshold, double gap,
                         const std::vector<std::size_t>& open, CoverOutput& out)
{
  // The open points are far from the outputs: only the points added count.
  const std::vector<std::size_t> kept =
      keepApart(open, [&](std::size_t i) { return Eigen::Vector3d(in.cloud[i].getVector3fMap().cast<double>()); }, gap);
  for (const std::size_t i : kept)
    addPointBall(in, params, error_threshold, i, out);
  return kept.size();
}

std::size_t fillGaps(const CoverInput& in, const Parameters& params, double error_threshold, double gap,
                     CoverOutput& out)
{
  return fillOpenGaps(in, params, error_threshold, gap, gapOpenPoints(in, params, out, gap), out);
}

std::size_t fillToCount(const CoverInput& in, const Parameters& params, double error_threshold, std::size_t count,
                        CoverOutput& out, double within, std::size_t measured_first)
{
  if (count == 0)
    return 0;
  auto position = [&](std::size_t i) { return Eigen::Vector3d(in.cloud[i].getVector3fMap().cast<double>()); };
  // A covered point's distance to its own representative bounds its distance to the output from
  // above; the largest of those is the grid's side, so a query within it finds the nearest output.
  using Entry = std::pair<double, std::size_t>;  // squared distance, then the lower index first
  std::vector<Entry> entries;
  double side2 = 0.0;
  for (std::size_t i = 0; i < in.cloud.size(); ++i)
  {
    const int o = out.owner[i];
    if (o < 0)
      continue;
    const double d2 = (position(i) - out.balls[static_cast<std::size_t>(o)].representative).squaredNorm();
    if (d2 > 0.0)
      entries.emplace_back(d2, i);
    side2 = std::max(side2, d2);
  }
  if (entries.empty())
    return 0;
  const double side = std::sqrt(side2);
  // After a gap bound every covered point lies within it of an output point: the nearest one is
  // looked for in a grid of that side, and in one of the largest bound's only when it is not found
  // there (never, when `within` is the bound fillGaps applied last).
  const std::vector<Eigen::Vector3d> output_positions = outputPositions(in, out);
  const double near_side = within > 0.0 && within < side ? within : side;
  PointGrid outputs(near_side);
  for (const Eigen::Vector3d& p : output_positions)
    outputs.insert(p);
  std::unique_ptr<PointGrid> wide_outputs;
  auto nearestOutput = [&](const Eigen::Vector3d& p, double bound2) {
    const double r = std::sqrt(bound2);
    if (r <= near_side)
      return outputs.nearestSquared(p, r, bound2);
    return outputs.nearestSquared(p, near_side, -1.0);  // -1: not within near_side
  };
  auto before = [](const Entry& a, const Entry& b) { return a.first < b.first || (a.first == b.first && a.second > b.second); };
  // Exact distances (to the output points, in parallel: the grid is only read) replace the bounds
  // of the entries with the largest bounds, `first` of them up front: the points taken come from
  // among those unless many bounds are loose. The others, [next, end), are measured in batches
  // (largest bounds first, each batch as large as all before it) when the largest of their bounds
  // comes above the queue's top, so that the queue is always topped by the entry a queue of every
  // entry would have on top.
  const int threads = std::max(1, resolveThreads(params.threads));
  auto larger = [&](const Entry& a, const Entry& b) { return before(b, a); };
  auto measureLargest = [&](std::size_t from, std::size_t k) {
    const auto begin = entries.begin() + static_cast<std::ptrdiff_t>(from);
    std::nth_element(begin, begin + static_cast<std::ptrdiff_t>(k) - 1, entries.end(), larger);
    const auto n = static_cast<std::ptrdiff_t>(k);
    std::vector<std::uint8_t> missed(k, 0);  // no output point within near_side: the bound stands
#pragma omp parallel for schedule(dynamic, 4096) num_threads(threads)
    for (std::ptrdiff_t c = 0; c < n; ++c)
    {
      Entry& e = entries[from + static_cast<std::size_t>(c)];
      const double d2 = nearestOutput(position(e.second), e.first);
      if (d2 < 0.0)
        missed[static_cast<std::size_t>(c)] = 1;
      else
        e.first = d2;
    }
    // Those are measured in the wide grid.
    for (std::size_t c = 0; c < k; ++c)
    {
      if (!missed[c])
        continue;
      if (!wide_outputs)
      {
        wide_outputs = std::make_unique<PointGrid>(side);
        for (const Eigen::Vector3d& p : output_positions)
          wide_outputs->insert(p);
      }
      Entry& e = entries[from + c];
      e.first = wide_outputs->nearestSquared(position(e.second), std::sqrt(e.first), e.first);
    }
  };
  const std::size_t first = std::min(entries.size(), std::max(4 * count, measured_first));
  measureLargest(0, first);
  // Lazy greedy farthest-point insertion: a stored distance only overstates the current one (it
  // is a bound, or exact before the points added since, which can only be nearer), so the point
  // at the top of the queue is measured against the points added and taken when it still is at
  // least the next one's stored distance.
  std::priority_queue<Entry, std::vector<Entry>, decltype(before)> queue(
      before, std::vector<Entry>(entries.begin(), entries.begin() + static_cast<std::ptrdiff_t>(first)));
  std::size_t next = first;
  auto largestUnmeasured = [&] { return *std::max_element(entries.begin() + static_cast<std::ptrdiff_t>(next), entries.end(), before); };
  Entry unmeasured_top = next < entries.size() ? largestUnmeasured() : Entry{};
  auto settle = [&] {
    while (next < entries.size() && (queue.empty() || before(queue.top(), unmeasured_top)))
    {
      const std::size_t k = std::min(entries.size() - next, next);
      measureLargest(next, k);
      for (std::size_t c = next; c < next + k; ++c)
        queue.push(entries[c]);
      next += k;
      if (next < entries.size())
        unmeasured_top = largestUnmeasured();
    }
  };
  PointGrid added_grid(side);
  std::size_t added = 0;
  while (added < count && (settle(), !queue.empty()))
  {
    const auto [stored, i] = queue.top();
    queue.pop();
    settle();
    const Eigen::Vector3d p = position(i);
    const double d2 = std::min(stored, added_grid.nearestSquared(p, side, stored));
    if (!(d2 > 0.0))
      continue;  // an output point sits on it
    if (d2 < stored && !queue.empty() && before(Entry{d2, i}, queue.top()))
    {
      queue.emplace(d2, i);
      continue;
    }
    addPointBall(in, params, error_threshold, i, out);
    added_grid.insert(p);
    ++added;
  }
  return added;
}

}  // namespace pcl_ecs
