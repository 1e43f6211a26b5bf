// pcl_ecs — feature-preserving, error-controllable point cloud simplification.
// parameters.h: the one parameter set of the method, its defaults and its validator.
// Every front end (the filter, pcd_simplify, the streaming path, the node, the viewer) fills this
// struct and goes through validate(); nothing else decides what a valid value is.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace pcl_ecs
{

/** \brief Which error function E(r) the radius solve uses (paper eq. 14).
 *
 * - Normalized: E(r) = sqrt(Q(x_min) / sum_j a_j G) / L, a weighted RMS distance from the
 *   representative to the neighbours' tangent planes, as a fraction of L. Scale-free: T_err means
 *   the same on every model and every unit.
 * - Paper: E(r) = sqrt(Q(x_min)) / L, the paper's literal formula. It grows with the model's units
 *   and with the number of points in the ball; use it to reproduce the paper's tables.
 */
enum class ErrorForm
{
  Normalized,
  Paper
};

/** \brief Name of an error form ("normalized" / "paper"). */
const char* toString(ErrorForm form);
/** \brief Parse "normalized" / "paper"; returns false for anything else. */
bool parseErrorForm(const std::string& text, ErrorForm& form);

/** \brief All parameters of FeatureAwareCoverSimplify, with documented defaults and ranges. */
struct Parameters
{
  /** \brief T_err, the error bound of a ball (paper eq. 15), as a fraction of L.
   * Range: (0, 1). Default 1e-3: with the normalized form a weighted RMS distance of 0.1% of L
   * from a representative to the tangent planes it replaces. */
  double error_threshold = 1e-3;

  /** \brief T_err in the input's units instead (a distance: survey users think in metres); when
   * > 0 it replaces error_threshold with error_threshold_abs / L, which must lie in (0, 1). Not with
   * a target size. Range: 0 (off) or > 0. */
  double error_threshold_abs = 0.0;

  /** \brief α, the feature factor of eq. 4: a point is a feature point when its measure exceeds
   * α times the mean measure. Range: > 0 (values below 1 make most points features).
   * Default 6: on noisy scans of CAD parts α = 3 turns a band several points wide along every
   * edge into features; 6 keeps the edges themselves (see docs/RESULTS.md). */
  double feature_factor = 6.0;

  /** \brief K, the size of the one neighbourhood used by eq. 1, 2, 3 and 7-12 (the point itself
   * excluded). Range: [5, 200]. Default 16. */
  int k_neighbors = 16;

  /** \brief The error form of E(r). Default Normalized. */
  ErrorForm error_form = ErrorForm::Normalized;

  /** \brief Step 5: adapt T_err per ball to local curvature and density. Default on. */
  bool adaptive = true;

  /** \brief Step 5: the factor by which T_err is raised in flat and sparse regions and lowered in
   * curved and dense ones. Range: [1, 100] (1 is the same as adaptation off). Default 2. */
  double adaptive_factor = 2.0;

  /** \brief The cap on a ball's radius, in multiples of the mean neighbourhood radius of the
   * non-feature points (the mean of sqrt(a_i), eq. 1: the RMS distance to the K neighbours; on a
   * square grid with K = 16 it is 1.73 spacings). Range: (0, 1000]. Default 5 (about 8.7 grid
   * spacings). Stops one ball from swallowing a whole flat face; raise it for stronger reduction
   * of flat scans. */
  double radius_cap_factor = 5.0;

  /** \brief In target-size mode only: the radius cap follows the target, at this many times the
   * spacing the target implies for the balls (the mean neighbourhood radius × sqrt(non-feature
   * points / (K × balls wanted))), instead of radius_cap_factor. Balls then stay comparable to the
   * output spacing: coverage and surface deviation improve (docs/RESULTS.md). When the size cannot
   * be reached with it (targets close to the input size), the cap is widened in ×1.5 steps up to
   * radius_cap_factor. 0 keeps radius_cap_factor. Range: 0 or (0, 1000]. Default 2.5. */
  double target_radius_cap = 2.5;

  /** \brief The ball's optimised point x_min is its representative when it lies within this
   * fraction of the radius from the centre; otherwise the centre is. The paper's rule is 1 (inside
   * the ball). Range: (0, 1]. Default 0.5: an optimised point near the rim leaves the far side of the
   * ball uncovered; bounding it lowers the coverage distance (docs/RESULTS.md). */
  double max_representative_offset = 0.5;

  /** \brief The representative's own pseudo-inverse cutoff: the ball's point is the minimiser of
   * its quadric (eq. 13) over the directions whose eigenvalue is above this fraction of the
   * largest, and stays at the centre along the others. E(r) keeps the finer cutoff of
   * stages/quadric.h (1e-3), so the radius is the paper's. Range: (0, 1] (1: the centre itself).
   * Default 0.05: on a curved or noisy patch the planes' normals differ only a little, the weak
   * directions of the quadric are tangential and ill-conditioned (noise in the normals moves the
   * minimiser along the surface by up to half the radius); holding them at the centre keeps the
   * output as evenly spread as the centres while the strong directions (across the surface, and
   * across an edge) still move the point onto the fitted surface (docs/RESULTS.md). */
  double representative_cutoff = 0.05;

  /** \brief A ball whose points scatter about their tangent planes by more than this fraction of
   * its radius (sqrt(Q(x_min) / Σ w_j) / r, the RMS distance of the optimised point to the
   * planes, relative to r) is represented by its centre, an input point: there the points do not
   * describe a surface the planes agree on (vegetation, mixed returns, heavy noise) and an
   * optimised point lands between the layers. Range: (0, 10] (2 or more: never, Q(x_min) <= Q(c)
   * and every plane is within 2r of c). Default 0.2: balls on smooth surfaces scatter by a few
   * hundredths of r, balls on vegetation by more than 0.2 (docs/RESULTS.md). */
  double max_roughness = 0.2;

  /** \brief Place the representative of a smooth ball (its quadric has one dominant direction) on
   * the weighted least-squares quadratic through its points, along the centre's normal, and that
   * of a ball no quadratic fits at its member nearest to the optimised point
   * (stages/representative_fit.h): on curved and noisy scans the output points then lie on the
   * surface, not off it by the planes' bias or the noise. Default on; off is the paper's method. */
  bool representative_fit = true;

  /** \brief After the cover, move each representative that lies on its ball's fitted quadratic
   * towards the centroid of the points nearest to it, along that quadratic: one step of Lloyd's
   * algorithm on the surface (stages/representative_relax.h). The output then stands for its points
   * more evenly: nearer to them, and on the surface. Needs representative_fit (without it no
   * representative lies on a fit). Default on; off is the paper's method. */
  bool relax_representatives = true;

  /** \brief The gap bound (stages/gap_fill.h), in the T_err mode and out of core: after the
   * cover, every point farther than this many times the radius cap from all output points becomes
   * an output point of its own, greedily, so that no input point is farther than
   * max_gap_factor × cap from the output (the paper's cover leaves up to 1.5 × cap where an
   * optimised point sits off its ball's centre). 0 turns it off (the paper's method). Range: 0 or
   * (0, 100]. Default 1: no point farther than the largest ball radius from the output. */
  double max_gap_factor = 1.0;

  /** \brief The gap bound in target-size mode, as a multiple of the cap the target implies
   * (target_radius_cap; max_gap_factor applies when that is 0). Tighter than in the T_err mode:
   * at a given output size it lowers the coverage max where large balls meet (flat regions, scan
   * borders; docs/RESULTS.md). When the size cannot be reached with it, the
   * search widens it in ×1.1 steps up to the cap. 0 turns it off. Range: 0 or (0, 100]. Default 0.6. */
  double target_gap_factor = 0.6;

  /** \brief Feature points thinned along the edges to one per this many mean neighbourhood radii
   * (stages/feature_thinning.h): on a noisy scan eq. 4 marks a band several points wide along every
   * sharp edge, which a small output cannot afford. A dropped feature point is stood for by a kept
   * one within that distance. 0 keeps every feature point (the paper's method). With a target
   * size the search sets it (half the spacing the target implies, wider while the feature points
   * would take more than a third of the target) and Summary::feature_spacing says what it used, so a
   * plain run with it reproduces the output. Range: 0 or (0, 1000]. Default 0. */
  double feature_spacing = 0.0;

  /** \brief A bound on the error a user means: every input point ends within this distance (input
   * units) of the output's surface (stages/surface_deviation.h: the plane of its 8 nearest output
   * points, or its nearest output point when closer); points that would lie farther become output
   * points of their own. 0 (default) measures and reports the deviation without bounding it.
   * Not with a target size (the points it adds change the size). Range: 0 or > 0. */
  double max_deviation = 0.0;
  /** \brief The same bound as a fraction of L, the bounding box's diagonal (`--max-deviation 0.1%`
   * is 0.001); at most one of the two is set. Range: 0 or (0, 1]. */
  double max_deviation_of_L = 0.0;

  /** \brief Measure every input point's deviation and report it (Summary::deviation_max, _p99,
   * _rms) without a bound; always done with a bound. Off by default: the measure costs about a
   * third of a plain run. Never changes the output. */
  bool report_deviation = false;

  /** \brief Seed of the order in which ball centres are picked (step 3). Same seed, same input,
   * same parameters: the same output bit for bit, whatever the thread count. */
  std::uint64_t seed = 42;

  /** \brief Use the normals carried by the input (normal_x/y/z) instead of estimating them.
   * Only meaningful for point types with normals; non-finite or zero normals are refused. */
  bool use_input_normals = false;

  /** \brief Worker threads for the per-point stages; 0 means all hardware threads.
   * Range: [0, 1024]. The output does not depend on it. */
  int threads = 0;

  /** \brief If non-zero, search T_err so that the output holds this many points (within 1%, or
   * the closest size reachable). Overrides error_threshold (the search starts at 4e-3). */
  std::size_t target_size = 0;
};

/** \brief Check every field; returns an empty string when valid, otherwise one sentence naming
 * the first bad field and its value. */
std::string validate(const Parameters& params);

/** \brief The thread count actually used for `requested` (0 = all hardware threads). */
int resolveThreads(int requested);

}  // namespace pcl_ecs
