#include <pcl_ecs/spatial_order.h>
#include <pcl_ecs/types.h>

#include "detail/radix_sort.h"
#include "detail/uninitialised_allocator.h"

#include <algorithm>
#include <limits>
#include <cmath>
#include <utility>

namespace pcl_ecs
{

namespace
{
constexpr int kBits = 21;           // per axis at most: 63 bits in all
constexpr int kLanes = 8;           // points encoded side by side
constexpr double kTop = 2097151.0;  // 2^21 - 1

/// Spread the low 21 bits of v so that two zero bits separate each.
inline std::uint64_t spread(std::uint64_t v)
{
  v &= 0x1FFFFFull;
  v = (v | (v << 32)) & 0x1F00000000FFFFull;
  v = (v | (v << 16)) & 0x1F0000FF0000FFull;
  v = (v | (v << 8)) & 0x100F00F00F00F00Full;
  v = (v | (v << 4)) & 0x10C30C30C30C30C3ull;
  v = (v | (v << 2)) & 0x1249249249249249ull;
  return v;
}

/// Grid coordinates of p: cubic cells over [lo, lo + extent].
inline std::uint32_t cellOf(double x, double lo, double extent)
{
  double t = extent > 0.0 ? (x - lo) / extent : 0.0;
  t = std::min(std::max(std::isfinite(t) ? t : 0.0, 0.0), 1.0);
  return static_cast<std::uint32_t>(t * kTop);
}

/// Hilbert indices of kLanes grid points (X[axis][lane], `bits` bits per axis), by J. Skilling's
/// transpose algorithm ("Programming the Hilbert curve", AIP Conf. Proc. 707, 2004), written
/// without branches so that the lanes run side by side in vector registers. The index on the grid
/// of 2^b cells per axis is the top 3b bits of the index on the finer grid of 2^21 (X >> (21 - b)).
void hilbertLanes(std::uint32_t (&X)[3][kLanes], int bits, std::uint64_t* codes)
{
  std::uint32_t* x0 = X[0];
  std::uint32_t* x1 = X[1];
  std::uint32_t* x2 = X[2];
  // Undo the excess work of the inverse transform, from the top bit down; for each axis i: when
  // bit b of X[i] is set invert the low bits of X[0], else exchange the low bits of X[0] and X[i].
  for (int b = bits - 1; b > 0; --b)
  {
    const std::uint32_t low = (1u << b) - 1u;
    for (int j = 0; j < kLanes; ++j)
    {
      std::uint32_t a0 = x0[j], a1 = x1[j], a2 = x2[j];
      a0 ^= low & (0u - ((a0 >> b) & 1u));  // i = 0: the exchange is a no-op
      const std::uint32_t s1 = 0u - ((a1 >> b) & 1u);
      const std::uint32_t w1 = (a0 ^ a1) & low & ~s1;
      a0 ^= (low & s1) | w1;
      a1 ^= w1;
      const std::uint32_t s2 = 0u - ((a2 >> b) & 1u);
      const std::uint32_t w2 = (a0 ^ a2) & low & ~s2;
      a0 ^= (low & s2) | w2;
      a2 ^= w2;
      x0[j] = a0;
      x1[j] = a1;
      x2[j] = a2;
    }
  }
  // Gray encode.
  for (int j = 0; j < kLanes; ++j)
  {
    x1[j] ^= x0[j];
    x2[j] ^= x1[j];
  }
  std::uint32_t t[kLanes] = {};
  for (int b = bits - 1; b > 0; --b)
    for (int j = 0; j < kLanes; ++j)
      t[j] ^= ((1u << b) - 1u) & (0u - ((x2[j] >> b) & 1u));
  // The transposed index, interleaved: bit b of X[0], X[1], X[2], most significant first.
  for (int j = 0; j < kLanes; ++j)
    codes[j] = (spread(x0[j] ^ t[j]) << 2) | (spread(x1[j] ^ t[j]) << 1) | spread(x2[j] ^ t[j]);
}

/// Codes of points [first, first + count) (count <= kLanes), read through `at(i)`, `bits` per axis.
template <typename At>
void encodeBatch(const At& at, std::size_t first, std::size_t count, const Eigen::Vector3d& lo,
                 double extent, int bits, std::uint64_t* out)
{
  std::uint32_t X[3][kLanes] = {};
  for (std::size_t j = 0; j < count; ++j)
  {
    const Eigen::Vector3d p = at(first + j);
    for (int a = 0; a < 3; ++a)
      X[a][j] = cellOf(p(a), lo(a), extent) >> (kBits - bits);
  }
  std::uint64_t codes[kLanes];
  hilbertLanes(X, bits, codes);
  std::copy(codes, codes + count, out);
}
}  // namespace

std::uint64_t spatialCode(const Eigen::Vector3d& p, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi)
{
  std::uint64_t code = 0;
  spatialCodes(&p, 1, lo, hi, &code);
  return code;
}

void spatialCodes(const Eigen::Vector3d* points, std::size_t count, const Eigen::Vector3d& lo,
                  const Eigen::Vector3d& hi, std::uint64_t* codes, int bits, int threads)
{
  bits = std::min(std::max(bits, 1), kBits);
  const double extent = (hi - lo).maxCoeff();
  auto at = [points](std::size_t i) { return points[i]; };
  const auto batches = static_cast<std::ptrdiff_t>((count + kLanes - 1) / kLanes);
#pragma omp parallel for schedule(static) num_threads(std::max(1, threads)) if (threads > 1 && count >= 8192)
  for (std::ptrdiff_t b = 0; b < batches; ++b)
  {
    const std::size_t first = static_cast<std::size_t>(b) * kLanes;
    encodeBatch(at, first, std::min<std::size_t>(kLanes, count - first), lo, extent, bits, codes + first);
  }
}

double coincidenceTolerance(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, bool float_coordinates,
                            std::size_t count)
{
  const double largest = std::max(lo.cwiseAbs().maxCoeff(), hi.cwiseAbs().maxCoeff());
  if (!std::isfinite(largest) || count < 2)
    return 0.0;
  double ulps;
  if (float_coordinates)
  {
    const auto f = static_cast<float>(largest);
    ulps = 4.0 * static_cast<double>(std::nextafter(f, std::numeric_limits<float>::infinity()) - f);
  }
  else
    ulps = 4.0 * (std::nextafter(largest, std::numeric_limits<double>::infinity()) - largest);
  // Never more than 1% of the typical spacing (a surface of `count` points in the box): where the
  // coordinates' precision is what spaces the points (float UTM: 0.25 m), nearby points are
  // measurements, not copies.
  const double spacing = (hi - lo).norm() / std::sqrt(static_cast<double>(count));
  return std::min(ulps, 0.01 * spacing);
}

std::vector<std::pair<int, int>> sortAndMergeCoincident(std::vector<int>& ids,
                                                        const std::function<Eigen::Vector3d(int)>& position,
                                                        const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                                                        int threads)
{
  std::vector<std::uint64_t> codes;
  sortBySpatialCode(ids, position, lo, hi, threads, &codes);
  const std::size_t before = ids.size();
  std::vector<std::pair<int, int>> merged =
      removeCoincident(ids, codes, position, coincidenceTolerance(lo, hi, true, before));
  if (!merged.empty() && spatialOrderBits(ids.size()) != spatialOrderBits(before))
    sortBySpatialCode(ids, position, lo, hi, threads);
  return merged;
}

int spatialOrderBits(std::size_t count)
{
  int bits = 2;
  while (bits < kBits && (std::size_t{1} << (2 * (bits - 2))) < count)
    ++bits;
  return bits;
}

void sortBySpatialCode(std::vector<int>& ids, const std::function<Eigen::Vector3d(int)>& position,
                       const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int threads,
                       std::vector<std::uint64_t>* codes)
{
  threads = std::max(1, threads);
  struct Keyed
  {
    std::uint64_t code;
    int id;
  };
  // Filled (and its pages first touched) by the parallel loop, not zeroed first.
  std::vector<Keyed, UninitialisedAllocator<Keyed>> keyed(ids.size());
  const double extent = (hi - lo).maxCoeff();
  const int bits = spatialOrderBits(ids.size());
  auto at = [&](std::size_t i) { return position(ids[i]); };
  const auto batches = static_cast<std::ptrdiff_t>((ids.size() + kLanes - 1) / kLanes);
#pragma omp parallel for schedule(static) num_threads(threads)
  for (std::ptrdiff_t b = 0; b < batches; ++b)
  {
    const std::size_t first = static_cast<std::size_t>(b) * kLanes;
    const std::size_t count = std::min<std::size_t>(kLanes, ids.size() - first);
    std::uint64_t codes[kLanes];
    encodeBatch(at, first, count, lo, extent, bits, codes);
    for (std::size_t j = 0; j < count; ++j)
      keyed[first + j] = {codes[j], ids[first + j]};
  }
  // (code, id): by code, then ties by id, whatever the order of `ids`.
  radixSortThenTies(keyed, [](const Keyed& e) { return e.code; },
                    [](const Keyed& a, const Keyed& b) { return a.id < b.id; }, threads);
  for (std::size_t i = 0; i < ids.size(); ++i)
    ids[i] = keyed[i].id;
  if (codes)
  {
    codes->resize(ids.size());
    for (std::size_t i = 0; i < ids.size(); ++i)
      (*codes)[i] = keyed[i].code;
  }
}

std::vector<std::pair<int, int>> removeCoincident(std::vector<int>& ids, const std::vector<std::uint64_t>& codes,
                                                  const std::function<Eigen::Vector3d(int)>& position, double epsilon)
{
  // Coincident points share a cell, so they lie in one run of equal codes; within a run (a few
  // points, or many where a sensor wrote thousands of points at one spot) the run is ordered by
  // position, then id, and every point within epsilon (on each axis) of its group's first goes to
  // that first.
  std::vector<std::pair<int, int>> merged;
  std::vector<char> drop(ids.size(), 0);
  std::vector<std::size_t> run;
  for (std::size_t a = 0; a < ids.size();)
  {
    std::size_t b = a + 1;
    while (b < ids.size() && codes[b] == codes[a])
      ++b;
    if (b - a > 1)
    {
      run.resize(b - a);
      std::vector<Eigen::Vector3d> p(b - a);
      for (std::size_t k = a; k < b; ++k)
      {
        run[k - a] = k;
        p[k - a] = position(ids[k]);
      }
      std::sort(run.begin(), run.end(), [&](std::size_t u, std::size_t v) {
        const Eigen::Vector3d& pu = p[u - a];
        const Eigen::Vector3d& pv = p[v - a];
        if (pu.x() != pv.x()) return pu.x() < pv.x();
        if (pu.y() != pv.y()) return pu.y() < pv.y();
        if (pu.z() != pv.z()) return pu.z() < pv.z();
        return ids[u] < ids[v];
      });
      for (std::size_t k = 1, first = 0; k < run.size(); ++k)
      {
        if ((p[run[k] - a] - p[run[first] - a]).cwiseAbs().maxCoeff() <= epsilon)
        {
          drop[run[k]] = 1;
          merged.emplace_back(ids[run[k]], ids[run[first]]);
        }
        else
          first = k;
      }
    }
    a = b;
  }
  if (!merged.empty())
  {
    std::size_t w = 0;
    for (std::size_t i = 0; i < ids.size(); ++i)
      if (!drop[i])
        ids[w++] = ids[i];
    ids.resize(w);
  }
  return merged;
}

}  // namespace pcl_ecs
