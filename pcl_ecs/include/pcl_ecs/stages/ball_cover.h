// ball_cover.h — paper section 4, steps 2-7: cover the non-feature points with balls.
//   2. every non-feature point starts uncovered;
//   3. pick an uncovered point c (seeded order) and cover it;
//   4. solve the radius r and the optimised point (eq. 13-15, radius_solver.h);
//   5. with the tolerance adapted to c's curvature and density (adaptive_tolerance.h);
//   6. cover the points projected strictly inside the hull of the ball (hull_coverage.h);
//   7. until no point is uncovered.
// The representative is the minimiser of the ball's quadric along its well-determined directions
// (Parameters::representative_cutoff; at c along the others), unless the ball's points scatter
// about their planes by more than Parameters::max_roughness × r or that minimiser lies
// Parameters::max_representative_offset × r or farther from c: then c itself (the paper's rule
// is |x_min - c| < r: farther means a sharp region that slipped past the feature test). With
// Parameters::representative_fit, the minimiser is moved onto the quadratic fitted to the ball's
// points, or, where none fits, replaced by the member nearest to it among the points the cover
// has covered that no other ball stands at (representative_fit.h; c is always one of them, so
// no two representatives coincide), that member moved along c's normal onto the quadratic of the
// members near it where one fits them within the noise (kMemberFitSupport). Its attributes are those of the member nearest to it. One radius query per ball (re-issued larger
// only if the bracket outgrows it) serves every bisection step and the coverage.
//
// Parallel and deterministic: the centres are bucketed into cells of side > 2·cap coloured by the
// parity of their grid coordinates (8 colours); cells of one colour are processed concurrently
// (their balls cannot touch), colours one after another; the centres of a cell come in a seeded
// order of its own (seeded from the run's seed and the cell's key). The output depends on the seed
// and the cells, never on the thread count.
#pragma once

#include <pcl_ecs/parameters.h>
#include <pcl_ecs/stages/global_stats.h>
#include <pcl_ecs/stages/radius_solver.h>
#include <pcl_ecs/types.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <pcl/search/search.h>

namespace pcl_ecs
{

/** \brief What the cover reads; every vector is indexed like `cloud`. */
struct CoverInput
{
  const LocalCloud& cloud;
  const NormalList& normals;
  const std::vector<double>& weights;       ///< eq. 1
  const std::vector<std::uint8_t>& is_feature;
  const std::vector<double>& curvature;     ///< eq. 11 (H, signed)
  const std::vector<double>& density;       ///< eq. 5
  double mean_abs_curvature;                ///< eq. 12 on |H|
  double mean_density;                      ///< eq. 6
  /// unit of the radius cap: mean over the non-feature points of sqrt(a_i) (eq. 1), the RMS
  /// distance to the K neighbours; robust where eq. 5 is not (duplicates, quantised coordinates)
  double neighborhood_radius;
  double bbox_diagonal;                     ///< L
  /// eq. 3's mean over every point (GlobalStats::meanMeasure): the noise level against which a
  /// representative's fit is judged (representative_fit.h); 0: not known, no fit is refused for it
  double mean_measure;
  /// radius search over all of `cloud` (feature points in its results are skipped)
  const pcl::search::Search<pcl::PointXYZ>& search;
  /// optional (the out-of-core path): only points with a non-zero entry may be centres
  const std::vector<std::uint8_t>* centre_allowed = nullptr;
  /// optional (the out-of-core path): points covered already (by a neighbouring tile's balls);
  /// they still shape the quadrics but are neither centres nor claimed again (owner stays -1)
  const std::vector<std::uint8_t>* pre_covered = nullptr;
  /// optional (target size, stages/feature_thinning.h): feature point i is an output point only
  /// when (*feature_kept_by)[i] == i; the others are stood for by that kept one
  const std::vector<std::int64_t>* feature_kept_by = nullptr;

  /// Whether point i is an output point as a feature point.
  bool featureOutput(std::size_t i) const
  {
    return is_feature[i] && (!feature_kept_by || (*feature_kept_by)[i] == static_cast<std::int64_t>(i));
  }
};

/** \brief The cover's input: the per-point values of eq. 1-12 and the means over the whole cloud
 * that `stats` holds (eq. 3, 6, 12 and the radius unit), as the filter and every tile of the
 * out-of-core run take them. */
inline CoverInput makeCoverInput(const LocalCloud& cloud, const NormalList& normals, const std::vector<double>& weights,
                                 const std::vector<std::uint8_t>& is_feature, const std::vector<double>& curvature,
                                 const std::vector<double>& density, const GlobalStats& stats, double bbox_diagonal,
                                 const pcl::search::Search<pcl::PointXYZ>& search)
{
  return {cloud,
          normals,
          weights,
          is_feature,
          curvature,
          density,
          stats.meanAbsCurvature(),
          stats.meanSpacing(),
          stats.neighborhoodRadius(),
          bbox_diagonal,
          stats.meanMeasure(),
          search};
}

/** \brief One ball, in local-frame coordinates. */
struct CoverBall
{
  int centre = -1;
  double radius = 0.0;
  double tolerance = 0.0;
  double error = 0.0;
  Eigen::Vector3d representative = Eigen::Vector3d::Zero();
  bool used_centre = false;
  double roughness = 0.0;  ///< sqrt(Q(x_min) / sum of weights) / r (Parameters::max_roughness)
  int attribute_source = -1;  ///< member nearest to the representative (a real input point)
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();  ///< averaged over the ball, c's sign
  std::size_t replaced = 0;   ///< points whose owner is this ball
  std::size_t evaluations = 0;  ///< E(r) computed by the radius solve
  /// The representative lies on the quadratic fitted to the ball's points (representative_fit.h),
  /// `fit` its coefficients in the centre's tangent frame: relaxRepresentatives moves it along it.
  bool fitted = false;
  Eigen::Matrix<double, 6, 1> fit = Eigen::Matrix<double, 6, 1>::Zero();
  /// Where `fit` holds (representative_fit.h, kLocalFitSupport): within `fit_support` of the
  /// tangent position of `fit_at` (an offset from the centre); 0: over the whole ball.
  Eigen::Vector3d fit_at = Eigen::Vector3d::Zero();
  double fit_support = 0.0;
};

/** \brief Parameters::max_roughness: a ball this rough keeps its centre as its representative. */
inline bool tooRough(double roughness, const Parameters& params)
{
  return roughness > params.max_roughness;
}
inline bool tooRough(const CoverBall& ball, const Parameters& params)
{
  return tooRough(ball.roughness, params);
}

/** \brief An input point made an output point of its own: a ball of radius 0 whose representative is
 * its centre (the gap bound, a target size's top-up, the deviation bound, a centre whose floor
 * radius failed). The output holds its input record exactly (Ball::isOwnPoint in the result). */
inline bool isOwnPoint(const CoverBall& ball)
{
  return ball.radius == 0.0 && ball.used_centre;
}

/** \brief How far a ball's points scatter about the quadric's minimiser: sqrt(Q(x_min) / sum
 * of weights) / r (0 for a ball of radius 0). */
double ballRoughness(const RadiusSolution& sol);

/** \brief The representative rule: the optimised point's offset from the centre c, or nothing
 * when c itself stands for the ball. The optimised point is the minimiser of the ball's quadric
 * along its directions whose eigenvalue is above representative_cutoff × the largest (across the
 * surface, not along it); c stands for the ball when its points are too rough to agree on a
 * surface (roughness > max_roughness) or the optimised point lies max_representative_offset × r
 * or farther from c (the paper's rule is r itself: a sharp feature slipped past the feature test). */
std::optional<Eigen::Vector3d> representativeOffset(const RadiusSolution& sol, double roughness,
                                                    const Parameters& params);

/** \brief What a representative carries besides its position. */
struct BallAttributes
{
  int source = -1;  ///< the member nearest to the representative (ties: the lower index)
  Eigen::Vector3f normal = Eigen::Vector3f::UnitZ();  ///< the members' normals, c's sign, kernel-weighted
};

/** \brief The attributes of a ball whose members (point indices, offsets from the centre and
 * distances to it) and representative offset `v_offset` are given: the record of the member
 * nearest to the representative, and the members' normals turned to the centre's side, weighted
 * by the kernel G of the radius (equally for a ball of radius 0) and normalised. */
BallAttributes ballAttributes(const std::vector<int>& members, const std::vector<Eigen::Vector3d>& offsets,
                              const std::vector<double>& distances, const Eigen::Vector3d& v_offset,
                              const NormalList& normals, int centre, double radius);

/** \brief The cover. */
struct CoverOutput
{
  std::vector<CoverBall> balls;
  /// per point: the ball that covered it; -1 for feature points, but for a thinned-out one the gap
  /// bound made an output point of its own (gap_fill.h)
  std::vector<int> owner;
  double max_error = 0.0;
  std::size_t radius_evaluations = 0;
  /// balls[0, first_colour_balls) are the balls of the cells of the first colour (see above)
  std::size_t first_colour_balls = 0;
};

/** \brief Run steps 2-7 with tolerance `error_threshold` and the other settings of `params`
 * (error_form, adaptive, adaptive_factor, radius_cap_factor, seed, threads). */
void coverWithBalls(const CoverInput& in, const Parameters& params, double error_threshold,
                    CoverOutput& out);

/** \brief The same cover, run a colour at a time: `run(1)` makes the balls of the cells of the
 * first colour alone, the same in every respect as coverWithBalls's (that colour runs first and
 * reads nothing the others make), at a fraction of its cost; `finish` runs the other colours and
 * gives exactly coverWithBalls's output. Those cells are one in eight, spread evenly over the
 * cloud, so the whole cover's size is close to a fixed multiple of theirs: the target-size
 * search's cheap trials (simplify_core.cpp) run the first colour, and finish it only when the
 * trial is worth a whole cover. `in` must outlive the object. */
class ColourCover
{
public:
  ColourCover(const CoverInput& in, const Parameters& params, double error_threshold);
  ~ColourCover();
  ColourCover(ColourCover&&) noexcept;
  ColourCover& operator=(ColourCover&&) noexcept;
  /// Runs the colours up to `colours` (1-8) not run yet.
  void run(int colours);
  /// The balls of the first colour (after run(1)), in coverWithBalls's order.
  std::vector<CoverBall> firstColourBalls() const;
  /// Runs the remaining colours and moves the cover into `out`; the object is spent (any further
  /// call throws std::logic_error).
  void finish(CoverOutput& out);

private:
  struct State;
  State& state() const;
  std::unique_ptr<State> state_;
};

}  // namespace pcl_ecs
