// radix_sort.h (private) — a stable least-significant-digit radix sort on an unsigned 64-bit key.
// Stable: items with equal keys keep their order, so items laid out in a secondary order (the
// seeded rank, the input index) come out ordered by (key, that order) in a handful of linear
// passes instead of a comparison sort. Passes run only over the 11-bit digits in which the keys
// differ, so a key packed into few bits costs few passes.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace pcl_ecs
{

namespace radix_detail
{
/// The calling thread's team: its size and this thread's index in it (1 and 0 without OpenMP).
inline std::pair<std::size_t, std::size_t> team()
{
#ifdef _OPENMP
  return {static_cast<std::size_t>(omp_get_num_threads()),
          static_cast<std::size_t>(omp_get_thread_num())};
#else
  return {1, 0};
#endif
}
}  // namespace radix_detail

/// Sort `items` by key(item) (std::uint64_t), stably, on `threads` threads (inputs under 64k
/// items on one): each pass counts and moves contiguous chunks, a chunk's items going, in order,
/// after those of the chunks before it with the same digit. A stable sort has one result: the same
/// whatever the thread count. The scratch buffer has the items' allocator (one that leaves new
/// elements uninitialised spares it its zeroing).
template <class T, class A, class KeyFn>
void radixSortStable(std::vector<T, A>& items, KeyFn key, int threads = 1)
{
  constexpr int kBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kBits;
  const std::size_t n = items.size();
  if (n < 2)
    return;
  const int team_max = n < (std::size_t{1} << 16) ? 1 : std::max(1, threads);
  const std::uint64_t first = key(items[0]);
  std::uint64_t differ = 0;  // the bits in which some key differs from the first
  const auto count = static_cast<std::ptrdiff_t>(n);
#pragma omp parallel for reduction(| : differ) num_threads(team_max) if (team_max > 1)
  for (std::ptrdiff_t i = 0; i < count; ++i)
    differ |= key(items[static_cast<std::size_t>(i)]) ^ first;
  std::vector<T, A> buffer(n);
  std::vector<std::array<std::size_t, kBuckets>> start(static_cast<std::size_t>(team_max));
  for (int shift = 0; shift < 64; shift += kBits)
  {
    if (((differ >> shift) & (kBuckets - 1)) == 0)
      continue;  // every key has the same digit here: the pass would not move anything
#pragma omp parallel num_threads(team_max) if (team_max > 1)
    {
      const auto [team, t] = radix_detail::team();
      const std::size_t b = n * t / team, e = n * (t + 1) / team;
      std::array<std::size_t, kBuckets>& mine = start[t];
      mine.fill(0);
      for (std::size_t i = b; i < e; ++i)
        ++mine[(key(items[i]) >> shift) & (kBuckets - 1)];
#pragma omp barrier
#pragma omp single
      {
        std::size_t sum = 0;  // digit-major, then chunk: each chunk's place among equal digits
        for (std::size_t d = 0; d < kBuckets; ++d)
          for (std::size_t c = 0; c < team; ++c)
            sum += std::exchange(start[c][d], sum);
      }
      for (std::size_t i = b; i < e; ++i)
        buffer[mine[(key(items[i]) >> shift) & (kBuckets - 1)]++] = std::move(items[i]);
    }
    items.swap(buffer);
  }
}

/// Sort `items` by key(item), and items of equal keys by `tie_less`: the radix sort (on `threads`
/// threads), then a comparison sort of each run of equal keys (short where keys rarely tie).
template <class T, class A, class KeyFn, class Less>
void radixSortThenTies(std::vector<T, A>& items, KeyFn key, Less tie_less, int threads = 1)
{
  radixSortStable(items, key, threads);
  const auto n = static_cast<std::ptrdiff_t>(items.size());
  for (std::ptrdiff_t b = 0, e = 0; b < n; b = e)
  {
    const std::uint64_t k = key(items[static_cast<std::size_t>(b)]);
    for (e = b + 1; e < n && key(items[static_cast<std::size_t>(e)]) == k; ++e)
    {
    }
    if (e - b > 1)
      std::sort(items.begin() + b, items.begin() + e, tie_less);
  }
}

}  // namespace pcl_ecs
