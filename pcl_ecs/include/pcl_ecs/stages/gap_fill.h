// gap_fill.h — after the cover (ball_cover.h): no input point farther than a bound from the output.
// The paper adapts T_err so that no holes appear; a ball's representative may still sit up to
// r + |x_min - c| from the rim of its ball, and where large balls meet (flat regions, the edge of a
// scan) the distance from a point to the nearest output point can reach 1.5 × the radius cap.
// fillGaps bounds it: every non-feature point farther than `gap` from every output point (feature
// points and ball representatives) becomes an output point of its own, a ball of radius 0 centred
// on it, greedily in cloud order (each added point may close the gaps around it); so does a feature
// point the thinning left out (feature_thinning.h), which its kept feature point may stand for from
// farther than `gap`. Afterwards every covered point and every thinned-out feature point lies within
// `gap` of an output point.
#pragma once

#include <pcl_ecs/parameters.h>
#include <pcl_ecs/stages/ball_cover.h>

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace pcl_ecs
{

/** \brief Per point of `points`: 1 when no point of `outputs` lies within `gap` of it (all 0 when
 * `gap` is not a positive bound). Parallel on `threads`; independent of them. */
std::vector<std::uint8_t> farFrom(const std::vector<Eigen::Vector3d>& outputs,
                                  const std::vector<Eigen::Vector3d>& points, double gap, int threads);

/** \brief The greedy step on plain points: goes through `candidates` in order and keeps each one
 * that has no point of `outputs`, nor a candidate kept before it, within `gap`. Returns the
 * positions in `candidates` of the kept ones, ascending. The first test (against `outputs` alone)
 * runs on `threads` threads; the result does not depend on them. */
std::vector<std::size_t> closeGaps(const std::vector<Eigen::Vector3d>& outputs,
                                   const std::vector<Eigen::Vector3d>& candidates, double gap, int threads);

/** \brief The output's positions: the feature points of `in` (cloud order), then the balls'
 * representatives (ball order). */
std::vector<Eigen::Vector3d> outputPositions(const CoverInput& in, const CoverOutput& out);

/** \brief Makes input point `i` (a covered point, or a feature point the thinning left out) an
 * output point of its own: a ball of radius 0 centred on it, with the tolerance its centre would
 * get (error_threshold adapted as in the cover), its own attributes, taking the point over from
 * its previous ball, if any (owner and `replaced` updated). */
void addPointBall(const CoverInput& in, const Parameters& params, double error_threshold, std::size_t i,
                  CoverOutput& out);

/** \brief Add radius-0 balls until every point covered by `out`, and every feature point that
 * in.feature_kept_by leaves out, lies within `gap` of an output point (a kept feature point of `in`
 * or a representative of `out`); the added balls take over their point from its previous ball
 * (owner and `replaced` updated; a thinned-out feature point had none). `gap` <= 0 does nothing. The tolerance
 * of an added ball is the one its centre would get (error_threshold adapted as in the cover).
 * Deterministic: the result does not depend on params.threads. Returns the number of balls added. */
std::size_t fillGaps(const CoverInput& in, const Parameters& params, double error_threshold, double gap,
                     CoverOutput& out);

/** \brief fillGaps in two steps, for several bounds on one cover (the target-size search widens
 * the gap bound on a cover it keeps). gapOpenPoints gives the points fillGaps(`gap`) would start
 * from: every covered point, and every feature point in.feature_kept_by leaves out, that lies
 * farther than `gap` from its own output point and from every output point of `out` (ascending
 * indices; none when `gap` is not a positive bound). With `among`, the result of gapOpenPoints on
 * the same `out` at a bound at most `gap`, only those points are tested: a point within the smaller
 * bound of an output point is within `gap` of it. Parallel on params.threads, independent of them. */
std::vector<std::size_t> gapOpenPoints(const CoverInput& in, const Parameters& params, const CoverOutput& out,
                                       double gap, const std::vector<std::size_t>* among = nullptr);

/** \brief The greedy step of fillGaps on the points gapOpenPoints gave for `out` and `gap`: each,
 * in order, with no point added before it within `gap`, becomes a ball of its own (addPointBall).
 * fillOpenGaps(in, params, T, gap, gapOpenPoints(in, params, out, gap), out) is fillGaps(in, params,
 * T, gap, out). Returns the number of balls added. */
std::size_t fillOpenGaps(const CoverInput& in, const Parameters& params, double error_threshold, double gap,
                         const std::vector<std::size_t>& open, CoverOutput& out);

/** \brief Add `count` radius-0 balls, farthest first: each time the covered point farthest from
 * every output point (a feature point of `in`, a representative of `out`, a ball added before it)
 * becomes one (ties: the lower index), as addPointBall does. The target size uses it to reach its
 * size exactly from a cover a little short of it: the points go where the output leaves the
 * widest gaps. Returns the number added (fewer than `count` only when every covered point is an
 * output point already).
 * A point's distance to its own representative bounds its distance to the output: the points with
 * the `measured_first` (at least 4 × count) largest bounds are measured up front, in parallel, the
 * others in parallel batches (largest bounds first, each batch as large as all measured before it)
 * only when the largest of their bounds comes above the top of the farthest-first queue. With
 * `within` > 0, the gap bound fillGaps last applied to `out`, the nearest output point of a point is
 * looked for within that distance first (a grid of that side holds fewer points per cell than one
 * of the largest bound's). The result depends on neither `measured_first`, `within` nor
 * params.threads. */
std::size_t fillToCount(const CoverInput& in, const Parameters& params, double error_threshold, std::size_t count,
                        CoverOutput& out, double within = 0.0, std::size_t measured_first = 65536);

}  // namespace pcl_ecs
