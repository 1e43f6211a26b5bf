// result.h: what a run of the method reports besides the output cloud.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace pcl_ecs
{

/** \brief What an output point is. */
enum class PointLabel : std::uint8_t
{
  Feature = 1,        ///< a feature point (eq. 3-4), copied from the input unchanged
  Representative = 2  ///< the optimised point of one ball (eq. 13-15)
};

/** \brief One ball of the cover (section 4, steps 3-6). Distances are in the input's units. */
struct Ball
{
  std::int64_t centre_index = -1;  ///< index of the centre c in the input cloud
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();          ///< c
  Eigen::Vector3d representative = Eigen::Vector3d::Zero();  ///< v (x_min, on the fitted quadratic or the member nearest to it; or c)
  double radius = 0.0;       ///< r (0 when the ball holds its centre alone)
  double tolerance = 0.0;    ///< T_err used for this ball, after step 5
  double error = 0.0;        ///< E(r) reached; never above tolerance
  std::size_t replaced = 0;  ///< input points this ball covered (c included)
  bool used_centre = false;  ///< v = c: the ball was too rough, or its representative too far from c (ball_cover.h)
  std::size_t output_index = 0;  ///< index of v in the output cloud

  /// An input point made an output point of its own (radius 0, v = c: the gap bound, a target
  /// size's top-up, the deviation bound); the output holds its input coordinates exactly.
  bool isOwnPoint() const { return radius == 0.0 && used_centre; }
};

/** \brief Wall time of each stage, in seconds. */
struct StageTimings
{
  double preparation = 0;  ///< finite points, local frame
  double neighbors = 0;    ///< the one K-neighbourhood query
  double normals = 0;      ///< eq. 2
  double weights = 0;      ///< eq. 1
  double features = 0;     ///< eq. 3-4
  double density = 0;      ///< eq. 5-6
  double curvature = 0;    ///< eq. 7-12
  double cover = 0;        ///< steps 2-7 (all T_err tried, in target-size mode)
  double deviation = 0;    ///< measuring every input point's deviation (and holding max_deviation)
  double output = 0;       ///< assembling the output cloud
  double total = 0;
};

/** \brief Counts and extremes of one run. */
struct Summary
{
  std::size_t input_points = 0;      ///< points of the input (or of setIndices)
  std::size_t finite_points = 0;     ///< of those, the finite ones
  std::size_t merged_points = 0;     ///< of those, points at exactly the place of another, merged into it
  std::size_t feature_points = 0;    ///< m, the feature points in the output
  std::size_t thinned_features = 0;  ///< feature points left out, each within feature_spacing of a
                                     ///< kept one (stages/feature_thinning.h)
  double feature_spacing = 0;        ///< the feature thinning used, in mean neighbourhood radii (0: none)
  std::size_t balls = 0;             ///< n, the number of representatives
  std::size_t output_points = 0;     ///< m + n
  std::size_t centre_fallbacks = 0;  ///< balls whose representative is their centre
  std::size_t rough_balls = 0;       ///< of those, balls too rough for a point of their own (max_roughness)
  std::size_t gap_points = 0;        ///< of the balls, those of radius 0 added to close gaps (gap_fill.h)
  std::size_t size_points = 0;       ///< of the balls, those of radius 0 added to reach the target size exactly (fillToCount)
  double max_gap = 0;                ///< the gap bound used (input units; 0: off)
  double feature_threshold = 0;      ///< δ of eq. 4 (input units)
  double mean_spacing = 0;           ///< mean of eq. 5 (input units)
  double neighborhood_radius = 0;    ///< mean of sqrt(a_i) (eq. 1): the radius cap's unit
  double radius_cap_factor = 0;      ///< the cap used, in neighbourhood radii (follows the target in target mode)
  double mean_abs_curvature = 0;     ///< mean |H| of eq. 12 (1 / input units)
  double bbox_diagonal = 0;          ///< L
  double error_threshold = 0;        ///< T_err used (the one found, in target-size mode)
  double max_error = 0;              ///< largest E(r) over all balls
  /// Every input point's distance to the output's surface (stages/surface_deviation.h: to the
  /// plane of its 8 nearest output points, or its nearest output point when closer), input units:
  /// the largest, the 99th percentile and the RMS over the distinct input points
  double deviation_max = 0, deviation_p99 = 0, deviation_rms = 0;
  bool deviation_measured = false;   ///< the three above were measured (max_deviation or report_deviation)
  double max_deviation = 0;          ///< the deviation bound held (input units; 0: none asked for)
  std::size_t deviation_points = 0;  ///< of the balls, those of radius 0 added to hold it
  int target_iterations = 0;         ///< trials of the target-size search (T, cap, gap bound)
  int cover_passes = 0;              ///< of those, the ones that ran the whole cover (others reused it)
  int estimated_trials = 0;          ///< of those, the ones estimated from the cover's first colour (ColourCover)
  std::size_t target_size = 0;       ///< the size asked for (0: T_err mode)
  /// false when a target size was asked for and the output is not within 1% of it: the closest
  /// size the method reaches (every point a feature or its own ball, or the fewest balls the
  /// radius cap allows) is output_points
  bool target_reached = true;
  std::size_t radius_evaluations = 0;  ///< E(r) computed by the (last) cover run
  StageTimings timings;
};

/** \brief Everything a user can read after filter(). */
struct Result
{
  /// label of every output point, parallel to the output cloud
  std::vector<PointLabel> labels;
  /// for every output point, the input index it was taken from (the point itself for features,
  /// the point whose attributes a representative carries for balls)
  std::vector<std::int64_t> source_index;
  /// for every output point that is a representative, the index into `balls`; -1 for features
  std::vector<std::int64_t> ball_of_output;
  /// the balls, in the order they were made
  std::vector<Ball> balls;
  /// for every point of the input cloud (input->size()), the output point that stands for it;
  /// -1 for points that were not used (non-finite, or outside setIndices)
  std::vector<std::int64_t> input_to_output;
  Summary summary;
  /// empty on success; otherwise what went wrong
  std::string error;

  void clear() { *this = Result{}; }
};

/** \brief Per output point, the radius of the ball it stands for; 0 for a feature point and for an
 * input point kept as it is (a ball of radius 0). The sample radii surface::coconeReconstruct and
 * Cocone<PointT>::setSampleRadii take: with them Cocone refuses triangles between balls that do
 * not overlap, a point of radius 0 judged by the ball of its nearest neighbour that has one. */
inline std::vector<double> pointRadii(const Result& r)
{
  std::vector<double> radius(r.labels.size(), 0.0);
  for (std::size_t o = 0; o < r.ball_of_output.size() && o < radius.size(); ++o)
  {
    const std::int64_t b = r.ball_of_output[o];
    if (b >= 0 && static_cast<std::size_t>(b) < r.balls.size())
      radius[o] = r.balls[static_cast<std::size_t>(b)].radius;
  }
  return radius;
}

}  // namespace pcl_ecs
