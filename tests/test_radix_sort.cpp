// The private radix sort (pcl_ecs/src/radix_sort.h) against std::stable_sort.
#include "detail/radix_sort.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

namespace
{
using Item = std::pair<std::uint64_t, int>;  // key, position before the sort

std::vector<Item> randomItems(std::size_t n, std::uint64_t key_mask, unsigned seed)
{
  std::mt19937_64 rng(seed);
  std::vector<Item> v(n);
  for (std::size_t i = 0; i < n; ++i)
    v[i] = {rng() & key_mask, static_cast<int>(i)};
  return v;
}

TEST(RadixSort, StableAndEqualToStableSortForEveryKeyWidth)
{
  // Few bits (many ties: stability shows), bits spread over the word (skipped digits), all 64.
  for (const std::uint64_t mask : {0x7ull, 0xFFFFFull, 0xF00000000000F00Full, ~0ull})
  {
    std::vector<Item> v = randomItems(50000, mask, 7), expected = v;
    std::stable_sort(expected.begin(), expected.end(),
                     [](const Item& a, const Item& b) { return a.first < b.first; });
    pcl_ecs::radixSortStable(v, [](const Item& e) { return e.first; });
    EXPECT_EQ(v, expected) << "mask " << std::hex << mask;
  }
}

// On several threads: the same (unique) stable order for any thread count, including counts that
// do not divide the items evenly, and small inputs that it sorts on one thread.
TEST(RadixSort, ParallelEqualsStableSortWhateverTheThreads)
{
  for (const std::uint64_t mask : {0x7ull, 0xF00000000000F00Full, ~0ull})
    for (const std::size_t n : {std::size_t{1000}, std::size_t{200003}})
    {
      const std::vector<Item> input = randomItems(n, mask, 13);
      std::vector<Item> expected = input;
      std::stable_sort(expected.begin(), expected.end(),
                       [](const Item& a, const Item& b) { return a.first < b.first; });
      for (const int threads : {1, 2, 3, 4})
      {
        std::vector<Item> v = input;
        pcl_ecs::radixSortStable(v, [](const Item& e) { return e.first; }, threads);
        EXPECT_EQ(v, expected) << "mask " << std::hex << mask << std::dec << ", " << n << " items, "
                               << threads << " threads";
      }
    }
}

TEST(RadixSort, TiesOrderedByTheSecondKeyWhateverTheStartingOrder)
{
  std::vector<Item> v = randomItems(20000, 0x3FFull, 11);
  std::mt19937 rng(3);
  std::shuffle(v.begin(), v.end(), rng);  // positions no longer ascending
  std::vector<Item> expected = v;
  std::sort(expected.begin(), expected.end());
  pcl_ecs::radixSortThenTies(v, [](const Item& e) { return e.first; }, std::less<Item>());
  EXPECT_EQ(v, expected);
}

TEST(RadixSort, EmptyAndSingleAndAllEqual)
{
  std::vector<Item> none;
  pcl_ecs::radixSortStable(none, [](const Item& e) { return e.first; });
  EXPECT_TRUE(none.empty());
  std::vector<Item> one{{5, 0}};
  pcl_ecs::radixSortStable(one, [](const Item& e) { return e.first; });
  EXPECT_EQ(one, (std::vector<Item>{{5, 0}}));
  std::vector<Item> same{{9, 2}, {9, 0}, {9, 1}};
  pcl_ecs::radixSortStable(same, [](const Item& e) { return e.first; });
  EXPECT_EQ(same, (std::vector<Item>{{9, 2}, {9, 0}, {9, 1}}));  // untouched: stable
}
}  // namespace
