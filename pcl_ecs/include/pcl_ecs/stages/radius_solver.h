// radius_solver.h — paper eq. 13-15: the largest radius r of a ball centred at c whose error
// E(r) stays within the tolerance, and the optimised point x_min(r).
//
//   E(r) = sqrt(Q(x_min) / sum_j w_j) / L   (normalized, default: a weighted RMS distance)
//   E(r) = sqrt(Q(x_min)) / L               (paper, the literal eq. 14)
// with w_j = a_j G_{2r}(|p_j - c|) over the non-feature p_j within R = 2r.
//
// E is not strictly monotone on real data: the solve brackets first (from a guess, growing r until
// E exceeds the tolerance or r reaches the cap), then bisects, and keeps the largest r found with
// E(r) <= tolerance. If even the floor fails, the ball holds its centre alone (r = 0, E = 0): the
// reached error never exceeds the tolerance.
#pragma once

#include <pcl_ecs/parameters.h>
#include <pcl_ecs/stages/quadric.h>
#include <pcl_ecs/types.h>

#include <vector>

namespace pcl_ecs
{

/** \brief A candidate member of a ball: its distance to the centre (not squared) and index. */
struct BallCandidate
{
  /// Left uninitialised (a candidate list is resized and then written over, query after query).
  BallCandidate() {}
  BallCandidate(double d, int i) : distance(d), index(i) {}
  double distance;
  int index;
  bool operator<(const BallCandidate& o) const
  {
    return distance < o.distance || (distance == o.distance && index < o.index);
  }
};

/** \brief What the solver reads: points, unit normals and eq. 1 weights, all indexed alike. */
struct QuadricSamples
{
  const LocalCloud& cloud;
  const NormalList& normals;
  const std::vector<double>& weights;
};

/** \brief E(r) for `form` given the quadric's minimum; L is the bounding-box diagonal. */
double errorOf(const QuadricMinimum& minimum, double weight_sum, double L, ErrorForm form);

/** \brief E(r) and x_min(r) at one radius. */
struct RadiusEvaluation
{
  double radius = 0.0;
  double error = 0.0;
  QuadricMinimum minimum;
  Quadric quadric;  ///< eq. 13 at this radius (relative to the centre; its weight_sum is Σ w_j)
};

/** \brief The tangent planes of a ball's candidates as the terms each adds to eq. 13 (before the
 * kernel weight), in candidate order: computed once per radius query, read by every E(r). The
 * distances are kept apart from the terms so that E(r) picks the planes within 2r in a few
 * vector instructions. */
struct CandidatePlanes
{
  /// a_j × (n n^T: xx, xy, xz, yy, yz, zz; d n: x, y, z; d²; 1), d = n_j · (p_j - c), a_j eq. 1;
  /// the last is padding (0): whole SIMD pairs. Left uninitialised (candidatePlanes writes every
  /// field): growing the per-thread planes from ball to ball does not zero memory overwritten at once.
  struct Terms
  {
    Terms() {}  // NOLINT(modernize-use-equals-default): = default would value-initialise
    double t[12];
  };
  std::vector<double> distance;  ///< |p_j - c|, padded with +inf to a multiple of 4
  std::vector<Terms> terms;
  std::size_t size() const { return terms.size(); }
  void clear()
  {
    distance.clear();
    terms.clear();
  }
};

/** \brief The planes of `candidates`, in the same order; those before `first` are taken as
 * computed already (a source that appended candidates). */
void candidatePlanes(const QuadricSamples& samples, const Eigen::Vector3d& centre,
                     const std::vector<BallCandidate>& candidates, CandidatePlanes& planes,
                     std::size_t first = 0);

/** \brief Evaluate eq. 13-14 at radius r (> 0) over the `planes` within 2r. */
RadiusEvaluation evaluateRadius(const CandidatePlanes& planes, double r, double L, ErrorForm form);

/** \brief The same from the candidates (computes their planes first). */
RadiusEvaluation evaluateRadius(const QuadricSamples& samples, const Eigen::Vector3d& centre,
                                const std::vector<BallCandidate>& candidates, double r, double L,
                                ErrorForm form);

/** \brief The solve's answer. */
struct RadiusSolution
{
  double radius = 0.0;   ///< r; 0 when the ball holds its centre alone
  double error = 0.0;    ///< E(r) <= tolerance
  Eigen::Vector3d x_min = Eigen::Vector3d::Zero();  ///< offset from the centre
  double residual = 0.0;  ///< Q(x_min) >= 0
  Quadric quadric;        ///< eq. 13 at r, for a representative with another cutoff
  int evaluations = 0;   ///< how many E(r) were computed
};

/** \brief Called when the solver needs candidates out to `needed_query_radius`: it must make
 * `candidates` hold every non-feature point within that distance (in any order that is the same
 * from run to run: sums over them are made in that order), and return true when it changed them.
 * Candidates only grow: those held stay in place and new ones are appended (the solver keeps
 * what it derived from the first ones). */
struct CandidateSource
{
  virtual ~CandidateSource() = default;
  virtual bool ensure(double needed_query_radius, std::vector<BallCandidate>& candidates) = 0;
};

/** \brief Eq. 15 solved for r in [floor, cap].
 * The bracket starts at `guess` (clamped to [floor, cap]; a typical radius of recent balls saves
 * evaluations): if E(guess) <= tolerance it grows, each probe aimed just below the radius where
 * E ~ r^p meets the tolerance (p the log-log slope of the last two probes, 2 before there are
 * two; at least ×1/0.98, at most ×3) until E exceeds it or the cap is reached; otherwise the
 * radius E ~ r² predicts (just below it) is tried, then the floor, which must pass. Interpolation
 * in log E / log r (inside the inner 80% of the bracket; a probe that lands near the predicted
 * root is followed by one just across it, and a bracket within 4% is closed by one probe that
 * closes it whatever its outcome) stops when the bracket is within 2%.
 * \param[in] floor   smallest radius tried (the distance to c's nearest non-feature neighbour)
 * \param[in] cap     largest radius allowed (> 0)
 * \param[in] guess   first radius tried (<= 0: the floor)
 * \param[in] tolerance T_err for this ball (after step 5)
 * \param[in,out] source supplies candidates as larger radii are tried */
RadiusSolution solveRadius(const QuadricSamples& samples, const Eigen::Vector3d& centre,
                           double floor, double cap, double guess, double tolerance, double L,
                           ErrorForm form, CandidateSource& source,
                           std::vector<BallCandidate>& candidates);

}  // namespace pcl_ecs
