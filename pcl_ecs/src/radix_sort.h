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

namespace pcl_ecs
{

/// Sort `items` by key(item) (std::uint64_t), stably; `buffer` is scratch of the same type.
template <class T, class A, class KeyFn>
void radixSortStable(std::vector<T, A>& items, KeyFn key, std::vector<T, A>& buffer)
{
  constexpr int kBits = 11;
  constexpr std::size_t kBuckets = std::size_t{1} << kBits;
  const std::size_t n = items.size();
  if (n < 2)
    return;
  const std::uint64_t first = key(items[0]);
  std::uint64_t differ = 0;  // the bits in which some key differs from the first
  for (const T& item : items)
    differ |= key(item) ^ first;
  buffer.resize(n);
  std::array<std::size_t, kBuckets> start;
  for (int shift = 0; shift < 64; shift += kBits)
  {
    if (((differ >> shift) & (kBuckets - 1)) == 0)
      continue;  // every key has the same digit here: the pass would not move anything
    start.fill(0);
    for (const T& item : items)
      ++start[(key(item) >> shift) & (kBuckets - 1)];
    std::size_t sum = 0;
    for (std::size_t& s : start)
      sum += std::exchange(s, sum);
    for (T& item : items)
      buffer[start[(key(item) >> shift) & (kBuckets - 1)]++] = std::move(item);
    items.swap(buffer);
  }
}

/// The same with a buffer of its own (of the items' allocator: an allocator that leaves new
/// elements uninitialised spares the buffer its zeroing).
template <class T, class A, class KeyFn>
void radixSortStable(std::vector<T, A>& items, KeyFn key)
{
  std::vector<T, A> buffer;
  radixSortStable(items, key, buffer);
}

/// Sort `items` by key(item), and items of equal keys by `tie_less`: the radix sort, then a
/// comparison sort of each run of equal keys (short where keys rarely tie).
template <class T, class A, class KeyFn, class Less>
void radixSortThenTies(std::vector<T, A>& items, KeyFn key, Less tie_less)
{
  radixSortStable(items, key);
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
