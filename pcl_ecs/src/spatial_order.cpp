#include <pcl_ecs/spatial_order.h>
#include <pcl_ecs/types.h>

#include "radix_sort.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace pcl_ecs
{

namespace
{
/// Spread the low 21 bits of v so that two zero bits separate each.
std::uint64_t spread(std::uint64_t v)
{
  v &= 0x1FFFFFull;
  v = (v | (v << 32)) & 0x1F00000000FFFFull;
  v = (v | (v << 16)) & 0x1F0000FF0000FFull;
  v = (v | (v << 8)) & 0x100F00F00F00F00Full;
  v = (v | (v << 4)) & 0x10C30C30C30C30C3ull;
  v = (v | (v << 2)) & 0x1249249249249249ull;
  return v;
}
}  // namespace

std::uint64_t mortonCode(const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi)
{
  std::uint64_t code = 0;
  for (int k = 0; k < 3; ++k)
  {
    const double extent = hi(k) - lo(k);
    double t = extent > 0.0 ? (p(k) - lo(k)) / extent : 0.0;
    t = std::min(std::max(std::isfinite(t) ? t : 0.0, 0.0), 1.0);
    const auto cell = static_cast<std::uint64_t>(t * 2097151.0);  // 2^21 - 1
    code |= spread(cell) << k;
  }
  return code;
}

void sortByMortonCode(std::vector<int>& ids, const std::function<Eigen::Vector3d(int)>& position,
                      const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int threads)
{
  threads = std::max(1, threads);
  struct Keyed
  {
    std::uint64_t code;
    int id;
  };
  // Filled (and its pages first touched) by the parallel loop, not zeroed first.
  std::vector<Keyed, UninitialisedAllocator<Keyed>> keyed(ids.size());
  const auto count = static_cast<std::ptrdiff_t>(ids.size());
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::ptrdiff_t i = 0; i < count; ++i)
    keyed[static_cast<std::size_t>(i)] = {mortonCode(position(ids[static_cast<std::size_t>(i)]), lo, hi),
                                          ids[static_cast<std::size_t>(i)]};
  // (code, id): by code, then ties by id, whatever the order of `ids`.
  radixSortThenTies(keyed, [](const Keyed& e) { return e.code; },
                    [](const Keyed& a, const Keyed& b) { return a.id < b.id; });
  for (std::size_t i = 0; i < ids.size(); ++i)
    ids[i] = keyed[i].id;
}

}  // namespace pcl_ecs
