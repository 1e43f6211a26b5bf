#include <pcl_ecs/spatial_order.h>

#include <algorithm>
#include <random>
#include <utility>

#include <gtest/gtest.h>

// The Morton order: the code interleaves the axes' bits (x lowest), and the sort is by (code, id),
// the same with one thread or several (duplicated positions tie on the code and go by id).
TEST(SpatialOrder, MortonCodeInterleavesTheAxes)
{
  const Eigen::Vector3d lo(0, 0, 0), hi(1, 1, 1);
  EXPECT_EQ(pcl_ecs::mortonCode(lo, lo, hi), 0u);
  EXPECT_EQ(pcl_ecs::mortonCode(hi, lo, hi), (1ull << 63) - 1);  // 21 bits per axis, all set
  // The top cell of x alone: bit 60 (x is the lowest of each triple).
  EXPECT_EQ(pcl_ecs::mortonCode({0.75, 0.0, 0.0}, lo, hi) >> 60, 1u);
  EXPECT_EQ(pcl_ecs::mortonCode({0.0, 0.75, 0.0}, lo, hi) >> 60, 2u);
  EXPECT_EQ(pcl_ecs::mortonCode({0.0, 0.0, 0.75}, lo, hi) >> 60, 4u);
}

TEST(SpatialOrder, SortIsByCodeThenIdWhateverTheThreads)
{
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  std::vector<Eigen::Vector3d> pos;
  for (int i = 0; i < 200000; ++i)
    pos.emplace_back(u(rng), u(rng), u(rng));
  for (int i = 0; i < 5000; ++i)
    pos.push_back(pos[static_cast<std::size_t>(i * 13)]);  // exact duplicates
  const Eigen::Vector3d lo(-5, -5, -5), hi(5, 5, 5);
  std::vector<int> ids(pos.size());
  for (std::size_t i = 0; i < ids.size(); ++i)
    ids[i] = static_cast<int>(ids.size() - 1 - i);  // reversed: the sort has work to do
  std::vector<std::pair<std::uint64_t, int>> expected;
  for (int id : ids)
    expected.emplace_back(pcl_ecs::mortonCode(pos[static_cast<std::size_t>(id)], lo, hi), id);
  std::sort(expected.begin(), expected.end());
  auto position = [&](int id) { return pos[static_cast<std::size_t>(id)]; };
  for (int threads : {1, 2, 4})
  {
    std::vector<int> sorted = ids;
    pcl_ecs::sortByMortonCode(sorted, position, lo, hi, threads);
    ASSERT_EQ(sorted.size(), expected.size());
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < sorted.size(); ++i)
      wrong += sorted[i] != expected[i].second ? 1 : 0;
    EXPECT_EQ(wrong, 0u) << threads << " threads";
  }
}
