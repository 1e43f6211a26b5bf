#include <pcl_ecs/spatial_order.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <utility>

#include <gtest/gtest.h>

namespace
{
/// The cells of a g × g × g grid over the unit cube, sorted by the code of their centres.
std::vector<Eigen::Vector3i> cellsInCodeOrder(int g)
{
  const Eigen::Vector3d lo(0, 0, 0), hi(1, 1, 1);
  std::vector<std::pair<std::uint64_t, Eigen::Vector3i>> cells;
  for (int x = 0; x < g; ++x)
    for (int y = 0; y < g; ++y)
      for (int z = 0; z < g; ++z)
        cells.emplace_back(pcl_ecs::spatialCode(Eigen::Vector3d(x + 0.5, y + 0.5, z + 0.5) / g, lo, hi),
                           Eigen::Vector3i(x, y, z));
  std::sort(cells.begin(), cells.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<Eigen::Vector3i> out;
  for (std::size_t i = 0; i < cells.size(); ++i)
  {
    if (i > 0 && cells[i].first == cells[i - 1].first)
      ADD_FAILURE() << "two cells share a code";
    out.push_back(cells[i].second);
  }
  return out;
}
}  // namespace

// The Hilbert order: it starts at the box's low corner, and consecutive cells are face neighbours
// at every level (the curve never jumps, unlike the Morton order, which fails this test).
TEST(SpatialOrder, HilbertCurveStepsToAFaceNeighbourEachTime)
{
  const Eigen::Vector3d lo(0, 0, 0), hi(1, 1, 1);
  EXPECT_EQ(pcl_ecs::spatialCode(lo, lo, hi), 0u);
  EXPECT_LT(pcl_ecs::spatialCode(hi, lo, hi), 1ull << 63);  // 21 bits per axis
  for (int g : {2, 8, 64})
  {
    const std::vector<Eigen::Vector3i> path = cellsInCodeOrder(g);
    ASSERT_EQ(path.size(), static_cast<std::size_t>(g * g * g));
    EXPECT_EQ(path.front(), Eigen::Vector3i(0, 0, 0));
    std::size_t jumps = 0;
    for (std::size_t i = 1; i < path.size(); ++i)
      jumps += (path[i] - path[i - 1]).cwiseAbs().sum() != 1 ? 1 : 0;
    EXPECT_EQ(jumps, 0u) << g << "^3 cells";
  }
}

// Cells are cubes: in a flat box a point falls in the cell it would occupy in the cube of the
// box's longest side (a per-axis scale would cut a flat scan into slabs thinner than its relief).
TEST(SpatialOrder, CellsAreCubesWhateverTheBoxShape)
{
  const Eigen::Vector3d lo(0, 0, 0), flat(1, 1, 0.01), cube(1, 1, 1);
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.3, 0.7, 0.01), Eigen::Vector3d(0.9, 0.1, 0.004),
                                   Eigen::Vector3d(0.0, 0.0, 0.01)})
    EXPECT_EQ(pcl_ecs::spatialCode(p, lo, flat), pcl_ecs::spatialCode(p, lo, cube));
  // Outside the box: clamped to it; not a number: the low side.
  EXPECT_EQ(pcl_ecs::spatialCode(Eigen::Vector3d(-1, -1, -1), lo, cube), 0u);
  EXPECT_EQ(pcl_ecs::spatialCode(Eigen::Vector3d(2, 2, 2), lo, cube), pcl_ecs::spatialCode(cube, lo, cube));
  EXPECT_EQ(pcl_ecs::spatialCode(Eigen::Vector3d(std::nan(""), 0, 0), lo, cube), 0u);
}

// The batch form (several points per instruction, batches on any number of threads) gives the
// single form's codes, whatever the count (a multiple of the lane count or not; enough points for
// the threads to share them).
TEST(SpatialOrder, BatchCodesEqualSingleCodes)
{
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-2.0, 3.0);
  const Eigen::Vector3d lo(-2, -1, 0), hi(3, 2, 1);
  for (std::size_t count : {0u, 1u, 7u, 8u, 9u, 1001u, 20003u})
    for (const int threads : {1, 3})
    {
      std::vector<Eigen::Vector3d> pts;
      for (std::size_t i = 0; i < count; ++i)
        pts.emplace_back(u(rng), u(rng), u(rng));
      std::vector<std::uint64_t> codes(count, 0);
      pcl_ecs::spatialCodes(pts.data(), count, lo, hi, codes.data(), 21, threads);
      for (std::size_t i = 0; i < count; ++i)
        EXPECT_EQ(codes[i], pcl_ecs::spatialCode(pts[i], lo, hi)) << i << " of " << count << ", " << threads;
    }
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
  // On the grid the count calls for (fewer bits than the codes have: points share cells).
  const int bits = pcl_ecs::spatialOrderBits(pos.size());
  ASSERT_LT(bits, 21);
  std::vector<std::pair<std::uint64_t, int>> expected;
  for (int id : ids)
    expected.emplace_back(pcl_ecs::spatialCode(pos[static_cast<std::size_t>(id)], lo, hi) >> (3 * (21 - bits)), id);
  std::sort(expected.begin(), expected.end());
  auto position = [&](int id) { return pos[static_cast<std::size_t>(id)]; };
  for (int threads : {1, 2, 4})
  {
    std::vector<int> sorted = ids;
    pcl_ecs::sortBySpatialCode(sorted, position, lo, hi, threads);
    ASSERT_EQ(sorted.size(), expected.size());
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < sorted.size(); ++i)
      wrong += sorted[i] != expected[i].second ? 1 : 0;
    EXPECT_EQ(wrong, 0u) << threads << " threads";
  }
}

// The Hilbert index on a coarser grid is the top of the index on the finest one: ordering by the
// coarse code is ordering by the fine code with the points of one coarse cell tied.
TEST(SpatialOrder, CoarseCodesAreTheTopBitsOfFineCodes)
{
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 4.0);
  const Eigen::Vector3d lo(-1, -1, -1), hi(4, 3, 2);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 4001; ++i)
    pts.emplace_back(u(rng), u(rng), u(rng));
  std::vector<std::uint64_t> fine(pts.size()), coarse(pts.size());
  pcl_ecs::spatialCodes(pts.data(), pts.size(), lo, hi, fine.data());
  for (int bits : {1, 2, 5, 12, 20, 21})
  {
    pcl_ecs::spatialCodes(pts.data(), pts.size(), lo, hi, coarse.data(), bits);
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < pts.size(); ++i)
      wrong += coarse[i] != fine[i] >> (3 * (21 - bits)) ? 1 : 0;
    EXPECT_EQ(wrong, 0u) << bits << " bits";
  }
}

// About 16 cells per point on a surface across the box (4^(b-2) >= count), 21 at most.
TEST(SpatialOrder, GridBitsGrowWithTheCount)
{
  EXPECT_EQ(pcl_ecs::spatialOrderBits(0), 2);
  EXPECT_EQ(pcl_ecs::spatialOrderBits(1), 2);
  EXPECT_EQ(pcl_ecs::spatialOrderBits(2), 3);
  EXPECT_EQ(pcl_ecs::spatialOrderBits(522674), 12);
  EXPECT_EQ(pcl_ecs::spatialOrderBits(1u << 20), 12);
  EXPECT_EQ(pcl_ecs::spatialOrderBits((1u << 20) + 1), 13);
  EXPECT_EQ(pcl_ecs::spatialOrderBits(std::size_t{1} << 60), 21);
}

// Points that differ by rounding are the same point: with the tolerance for float coordinates of
// the box (4 ulps of its largest coordinate), a point 1 ulp away on every axis is merged into the
// first of its group, one 64 ulps away is not; exact duplicates still keep the smallest id.
TEST(SpatialOrder, PointsWithinRoundingAreMergedOthersAreNot)
{
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(100.0f, 200.0f);  // ulp(200f) = 1.5e-5
  std::vector<Eigen::Vector3d> pos;
  for (int i = 0; i < 20000; ++i)
    pos.emplace_back(u(rng), u(rng), u(rng));
  auto shifted = [](const Eigen::Vector3d& p, int ulps) {
    Eigen::Vector3d q;
    for (int a = 0; a < 3; ++a)
    {
      auto f = static_cast<float>(p[a]);
      for (int k = 0; k < ulps; ++k)
        f = std::nextafter(f, 1e9f);
      q[a] = f;
    }
    return q;
  };
  for (int i = 0; i < 1000; ++i)
    pos.push_back(shifted(pos[static_cast<std::size_t>(i)], 1));  // ids 20000..20999: merged
  for (int i = 1000; i < 2000; ++i)
    pos.push_back(shifted(pos[static_cast<std::size_t>(i)], 64));  // ids 21000..21999: kept
  for (int i = 2000; i < 3000; ++i)
    pos.push_back(pos[static_cast<std::size_t>(i)]);  // ids 22000..22999: exact, merged
  const Eigen::Vector3d lo(100, 100, 100), hi(200, 200, 200);
  const double eps = pcl_ecs::coincidenceTolerance(lo, hi, true, pos.size());
  EXPECT_DOUBLE_EQ(eps, 4.0 * (std::nextafter(200.0f, 1e9f) - 200.0f));
  EXPECT_LT(pcl_ecs::coincidenceTolerance(lo, hi, false, pos.size()), 1e-12);
  std::vector<int> ids(pos.size());
  for (std::size_t i = 0; i < ids.size(); ++i)
    ids[i] = static_cast<int>(i);
  auto position = [&](int id) { return pos[static_cast<std::size_t>(id)]; };
  std::vector<std::uint64_t> codes;
  pcl_ecs::sortBySpatialCode(ids, position, lo, hi, 1, &codes);
  const auto merged = pcl_ecs::removeCoincident(ids, codes, position, eps);
  std::size_t near = 0, exact = 0, wrong = 0;
  for (const auto& [gone, kept] : merged)
  {
    near += gone >= 20000 && gone < 21000 && kept == gone - 20000 ? 1 : 0;
    exact += gone >= 22000 && kept == gone - 20000 ? 1 : 0;
    wrong += (gone >= 21000 && gone < 22000) || gone < 20000 ? 1 : 0;
  }
  EXPECT_GE(near, 990u) << "a pair straddling a cell border may stay apart, rarely";
  EXPECT_EQ(exact, 1000u);
  EXPECT_EQ(wrong, 0u);
  EXPECT_EQ(ids.size() + merged.size(), pos.size());
}
