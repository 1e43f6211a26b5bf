// spatial_order.h — the order in which the method stores the points: Morton (Z-order) of their
// position, so that points close in space are close in memory and every neighbour query of every
// stage is cache-friendly (random-order scans are up to 5× slower to query otherwise).
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include <Eigen/Core>

namespace pcl_ecs
{

/** \brief The 63-bit Morton code of p in the box [lo, hi] (21 bits per axis). */
std::uint64_t mortonCode(const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi);

/** \brief Sort `ids` by the Morton code of position(id) in [lo, hi], ties by id: deterministic
 * (the same order for any `threads`, the number of threads used; `position` is called from
 * several at once). */
void sortByMortonCode(std::vector<int>& ids, const std::function<Eigen::Vector3d(int)>& position,
                      const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int threads = 1);

}  // namespace pcl_ecs
