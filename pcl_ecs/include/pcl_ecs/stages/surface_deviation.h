// surface_deviation.h — how far the input lies from the simplified cloud's surface: the error a
// user means, measured after the cover, and the bound `--max-deviation` enforces.
//
// The surface near an input point q is the least-squares plane of q's k nearest output points
// (k = 8; the normal is the eigenvector of their scatter with the smallest eigenvalue). q's
// deviation is its distance to that plane, or to its nearest output point when that is closer (an
// output point lies on the surface; where fewer than 3 output points exist there is no plane).
// boundDeviation() adds input points as output points (radius-0 balls, as the gap bound does)
// until every input point's deviation is within a bound.
#pragma once

#include <pcl_ecs/parameters.h>
#include <pcl_ecs/stages/ball_cover.h>

#include <cstddef>
#include <memory>
#include <vector>

#include <Eigen/Core>

namespace pcl_ecs
{

/** \brief One input point's distances to the output. */
struct PointDeviation
{
  double plane = 0.0;    ///< to the plane of its k nearest output points (= nearest below 3)
  double nearest = 0.0;  ///< to its nearest output point
  /// The deviation: the closer of the two.
  double distance() const { return plane < nearest ? plane : nearest; }
};

/** \brief The output points, searchable; queries are const and safe from several threads. */
class OutputSurface
{
public:
  /// `outputs` in the coordinates queries will use; `k` nearest points make a plane.
  explicit OutputSurface(const std::vector<Eigen::Vector3d>& outputs, int k = 8);
  ~OutputSurface();
  OutputSurface(const OutputSurface&) = delete;
  OutputSurface& operator=(const OutputSurface&) = delete;
  /// q's distances to the output (both 0 when there is no output point).
  PointDeviation at(const Eigen::Vector3d& q) const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/** \brief max, 99th percentile and RMS of a set of deviations (all 0 for none). */
struct DeviationSummary
{
  double max = 0.0, p99 = 0.0, rms = 0.0;
};
DeviationSummary summarizeDeviations(std::vector<double> deviations);

/** \brief The deviation (PointDeviation::distance) of every point of `cloud` from the output of
 * `in` and `out` (the feature points and the balls' representatives), in parallel on `threads`;
 * independent of them. */
std::vector<double> coverDeviations(const CoverInput& in, const CoverOutput& out, int threads);

/** \brief Makes every point of `in.cloud` lie within `bound` of the output's surface: rounds of
 * measuring every point and adding, in cloud order, each point farther than the bound as an
 * output point of its own (a ball of radius 0, taking the point over from its ball as gap_fill.h
 * does), skipping one that lies within half its distance to the nearest output of a point added
 * in the same round (that point may fix it); until no point is farther. An output point has
 * deviation 0, so this ends. `bound` <= 0 does nothing. Deterministic for any thread count.
 * Returns the points added; `deviations` gets every point's final deviation. */
std::size_t boundDeviation(const CoverInput& in, const Parameters& params, double error_threshold, double bound,
                           CoverOutput& out, std::vector<double>& deviations);

}  // namespace pcl_ecs
