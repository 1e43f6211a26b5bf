#include <pcl_ecs/stages/representative_relax.h>

#include <pcl_ecs/stages/gap_fill.h>
#include <pcl_ecs/stages/representative_fit.h>

#include "../detail/point_grid.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace pcl_ecs
{

std::size_t relaxRepresentatives(const CoverInput& in, double max_representative_offset, int threads, CoverOutput& out)
{
  const std::size_t n = in.cloud.size();
  if (out.balls.empty() || out.owner.size() != n)
    return 0;
  threads = std::max(1, threads);
  const auto count = static_cast<std::ptrdiff_t>(n);
  auto position = [&](std::size_t i) { return Eigen::Vector3d(in.cloud[i].getVector3fMap().cast<double>()); };

  // The cells: each covered point's nearest output (ties: the lower index). Its own representative
  // lies at a distance d from it, so the nearest output lies within d: a query of radius d on a grid
  // of the outputs whose side is at least d. Nearly every point lies within three times the median
  // ball radius of its representative (a query then visits few cells of that grid); the others are
  // queried afterwards on a grid as coarse as the farthest of them.
  const std::vector<Eigen::Vector3d> sites = outputPositions(in, out);
  const std::size_t features = sites.size() - out.balls.size();
  std::vector<double> radii;
  radii.reserve(out.balls.size());
  for (const CoverBall& b : out.balls)
    if (b.radius > 0.0)
      radii.push_back(b.radius);
  if (radii.empty())
    return 0;
  std::nth_element(radii.begin(), radii.begin() + static_cast<std::ptrdiff_t>(radii.size() / 2), radii.end());
  // Query radii carry a margin so that the own representative, at exactly that distance, is found.
  const double margin = 1.0 + 1e-9;
  const double fine_side = 3.0 * radii[radii.size() / 2];
  PointGrid fine(fine_side);
  for (std::size_t s = 0; s < sites.size(); ++s)
    fine.insert(sites[s], static_cast<std::int64_t>(s));
  std::vector<std::int32_t> cell(n, -1);
  std::vector<double> own(n, -1.0);  // set for the points left to the coarse grid
  double farthest = 0.0;
#pragma omp parallel for schedule(dynamic, 4096) num_threads(threads) reduction(max : farthest)
  for (std::ptrdiff_t ii = 0; ii < count; ++ii)
  {
    const auto i = static_cast<std::size_t>(ii);
    if (out.owner[i] < 0)
      continue;
    const Eigen::Vector3d p = position(i);
    const double r = (p - sites[features + static_cast<std::size_t>(out.owner[i])]).norm() * margin;
    if (r <= fine_side)
      cell[i] = static_cast<std::int32_t>(fine.nearest(p, r));
    else
    {
      own[i] = r;
      farthest = std::max(farthest, r);
    }
  }
  if (farthest > 0.0)
  {
    PointGrid coarse(farthest);
    for (std::size_t s = 0; s < sites.size(); ++s)
      coarse.insert(sites[s], static_cast<std::int64_t>(s));
#pragma omp parallel for schedule(dynamic, 4096) num_threads(threads)
    for (std::ptrdiff_t ii = 0; ii < count; ++ii)
    {
      const auto i = static_cast<std::size_t>(ii);
      if (own[i] > 0.0)
        cell[i] = static_cast<std::int32_t>(coarse.nearest(position(i), own[i]));
    }
  }

  // Centroids: the offsets from the ball's centre, each rounded to a unit of 2^-31 of the largest
  // radius and summed as integers, so that the sum does not depend on the order of the points (a
  // tile of the out-of-core run holds them in another order than the whole cloud). A point of a cell
  // lies within a few of the largest radii of the cell's centre, so an offset takes a few times 2^31
  // units and the sums stay far inside 64 bits.
  double largest = 0.0;
  for (const CoverBall& b : out.balls)
    largest = std::max(largest, b.radius);
  const double unit = std::ldexp(largest, -31);
  std::vector<std::array<std::int64_t, 3>> sum(out.balls.size(), std::array<std::int64_t, 3>{0, 0, 0});
  std::vector<std::size_t> members(out.balls.size(), 0);
  for (std::size_t i = 0; i < n; ++i)
    if (cell[i] >= static_cast<std::int32_t>(features))
    {
      const std::size_t b = static_cast<std::size_t>(cell[i]) - features;
      const Eigen::Vector3d d = position(i) - position(static_cast<std::size_t>(out.balls[b].centre));
      for (int a = 0; a < 3; ++a)
        sum[b][static_cast<std::size_t>(a)] += std::llround(d[a] / unit);
      ++members[b];
    }

  // The moves: tangentially to the centroid, then onto the fitted quadratic.
  std::vector<std::uint8_t> moved(out.balls.size(), 0);
  const auto balls = static_cast<std::ptrdiff_t>(out.balls.size());
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::ptrdiff_t bb = 0; bb < balls; ++bb)
  {
    const auto b = static_cast<std::size_t>(bb);
    CoverBall& ball = out.balls[b];
    if (!ball.fitted || members[b] == 0 || !(ball.radius > 0.0))
      continue;
    const std::size_t c = static_cast<std::size_t>(ball.centre);
    const Eigen::Vector3d centre = position(c);
    const Eigen::Vector3d normal = in.normals[c].cast<double>();
    const Eigen::Vector3d target =
        Eigen::Vector3d(static_cast<double>(sum[b][0]), static_cast<double>(sum[b][1]), static_cast<double>(sum[b][2])) *
        (unit / static_cast<double>(members[b]));
    const Eigen::Vector3d tangent = tangentPosition(target, normal);
    if (ball.fit_support > 0.0 &&
        !((tangent - tangentPosition(ball.fit_at, normal)).norm() < ball.fit_support))
      continue;  // the fit holds near where it was made (a large ball's, representative_fit.h)
    const Eigen::Vector3d x = onFittedHeight(ball.fit, ball.radius, normal, tangent);
    if (!(x.norm() < max_representative_offset * ball.radius) || !x.allFinite() || centre + x == ball.representative)
      continue;
    ball.representative = centre + x;
    moved[b] = 1;
  }

  // Attribute sources: the cell's point nearest to the new position (the distances in parallel, the
  // least in point order).
  std::vector<double> d2(n, std::numeric_limits<double>::infinity());
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::ptrdiff_t ii = 0; ii < count; ++ii)
  {
    const auto i = static_cast<std::size_t>(ii);
    if (cell[i] >= static_cast<std::int32_t>(features) && moved[static_cast<std::size_t>(cell[i]) - features])
      d2[i] = (position(i) - out.balls[static_cast<std::size_t>(cell[i]) - features].representative).squaredNorm();
  }
  std::vector<double> best(out.balls.size(), std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < n; ++i)
    if (d2[i] < std::numeric_limits<double>::infinity())
    {
      const std::size_t b = static_cast<std::size_t>(cell[i]) - features;
      if (d2[i] < best[b])
      {
        best[b] = d2[i];
        out.balls[b].attribute_source = static_cast<int>(i);
      }
    }
  return static_cast<std::size_t>(std::count(moved.begin(), moved.end(), 1));
}

std::size_t relaxRepresentatives(const CoverInput& in, const Parameters& params, CoverOutput& out)
{
  return params.relax_representatives
             ? relaxRepresentatives(in, params.max_representative_offset, resolveThreads(params.threads), out)
             : 0;
}

}  // namespace pcl_ecs
