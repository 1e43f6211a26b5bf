// spatial_order.h — the order in which the method stores the points: the Hilbert curve through
// their position, so that points close in space are close in memory and every neighbour query of
// every stage is cache-friendly (random-order scans are up to 5× slower to query otherwise).
// Unlike the Morton (Z) order, the Hilbert curve never jumps: consecutive cells are face
// neighbours, so a run of consecutive points is a compact patch (the K-neighbour table gathers
// candidates per run, and the box tree bounds runs). The cells are cubes (the box's longest side
// on every axis): a flat scan is not cut into slabs thinner than its relief.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace pcl_ecs
{

/** \brief The 63-bit Hilbert index of p on the 2^21-per-axis grid of cubic cells spanning the box
 * [lo, hi] (cell side: the box's longest side / (2^21 - 1); points outside are clamped). */
std::uint64_t spatialCode(const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);

/** \brief spatialCode() of `count` points at once (the same values; several lanes per
 * instruction, batches on `threads` threads: a point's code depends on it alone); with `bits` < 21,
 * the index on the coarser grid of 2^bits cells per axis, which is spatialCode() >> 3 (21 - bits)
 * (the Hilbert curve refines itself cell by cell). */
void spatialCodes(const Eigen::Vector3d* points, std::size_t count, const Eigen::Vector3d& lo,
                  const Eigen::Vector3d& hi, std::uint64_t* codes, int bits = 21, int threads = 1);

/** \brief Bits per axis of the grid sortBySpatialCode() orders `count` points on: 4^(b - 2) >= count
 * (about 16 cells per point on a surface filling the box's face, so that few points share a cell),
 * at most 21. */
int spatialOrderBits(std::size_t count);

/** \brief Sort `ids` by the Hilbert index of position(id) in [lo, hi] on the grid of
 * spatialOrderBits(ids.size()) bits per axis (spatialCode() >> 3 (21 - b): coarser codes need
 * fewer steps to encode and to sort), ties by id: deterministic (the same order for any `threads`,
 * the number of threads used; `position` is called from several at once). */
void sortBySpatialCode(std::vector<int>& ids, const std::function<Eigen::Vector3d(int)>& position,
                       const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int threads = 1,
                       std::vector<std::uint64_t>* codes = nullptr);

/** \brief Remove from `ids` (sorted by sortBySpatialCode, whose `codes` are given) every id whose
 * position is that of another id to within `epsilon` on each axis (0: exactly equal), among the
 * ids of its cell; one of each group stays: with epsilon 0 the smallest id, otherwise the first
 * by position (x, then y, then z, then id). Returns the pairs (removed id, id that stays).
 * Linear in the ids plus n log n within the runs of equal codes (the same cell), whatever the
 * number of coincident points. */
std::vector<std::pair<int, int>> removeCoincident(std::vector<int>& ids, const std::vector<std::uint64_t>& codes,
                                                  const std::function<Eigen::Vector3d(int)>& position,
                                                  double epsilon = 0.0);

/** \brief Sort `ids` (points of float coordinates in [lo, hi]) by sortBySpatialCode and remove
 * the coincident ones (removeCoincident with coincidenceTolerance): the order is then the one the
 * cloud without them would have (sorted again when fewer points call for a coarser grid). Returns
 * the pairs (removed id, id that stays). What the filter does first; also counts distinct points. */
std::vector<std::pair<int, int>> sortAndMergeCoincident(std::vector<int>& ids,
                                                        const std::function<Eigen::Vector3d(int)>& position,
                                                        const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                                                        int threads = 1);

/** \brief The distance below which two of `count` points in [lo, hi] count as the same point:
 * 4 units in the last place of the largest coordinate, in float or double as the coordinates are
 * stored (points that differ by rounding: a re-export, a transform, a merge of scans), but never
 * more than 1% of the typical spacing |hi - lo| / sqrt(count) (where the precision itself spaces
 * the points, as in float UTM coordinates, points further apart are measurements, not copies). */
double coincidenceTolerance(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, bool float_coordinates,
                            std::size_t count);

}  // namespace pcl_ecs
