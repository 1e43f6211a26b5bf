#include <pcl_ecs/neighborhood.h>
#include <pcl_ecs/search/box_tree_search.h>
#include <pcl_ecs/search/nanoflann_search.h>
#include <pcl_ecs/spatial_order.h>

#include "detail/simd.h"  // private: switch the AVX2 loops off and on
#include "synthetic_shapes.h"

#include <algorithm>
#include <cmath>

#include <gtest/gtest.h>
#include <pcl/search/kdtree.h>

using namespace pcl_ecs_test;

namespace
{
/// Brute force: the k smallest (squared distance, index) pairs of point i, itself left out, the
/// squared distances computed in float as the searches compute them.
std::vector<std::pair<float, int>> bruteForceNearest(const Cloud& cloud, std::size_t i, int k)
{
  std::vector<std::pair<float, int>> all;
  for (std::size_t j = 0; j < cloud.size(); ++j)
    if (j != i)
    {
      const pcl::PointXYZ &a = cloud[i], &b = cloud[j];
      const float dx = a.x - b.x, dy = a.y - b.y, dz = a.z - b.z;
      all.emplace_back(dx * dx + dy * dy + dz * dz, static_cast<int>(j));
    }
  std::partial_sort(all.begin(), all.begin() + k, all.end());
  all.resize(static_cast<std::size_t>(k));
  return all;
}
}  // namespace

TEST(Neighborhood, MatchesBruteForceAndExcludesSelf)
{
  Rng rng(3);
  auto cloud = std::make_shared<Cloud>();
  for (int i = 0; i < 600; ++i)
    cloud->push_back(toPoint({rng.uniform(), rng.uniform(), rng.uniform()}));
  pcl::search::KdTree<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  pcl_ecs::NeighborhoodTable table;
  ASSERT_EQ(pcl_ecs::computeNeighborhoods(*cloud, tree, 10, 2, table), pcl_ecs::Status::Ok);
  ASSERT_EQ(table.size(), cloud->size());
  for (std::size_t i = 0; i < cloud->size(); ++i)
  {
    std::vector<std::pair<float, int>> all;
    for (std::size_t j = 0; j < cloud->size(); ++j)
      if (j != i)
        all.emplace_back(((*cloud)[i].getVector3fMap() - (*cloud)[j].getVector3fMap()).squaredNorm(),
                         static_cast<int>(j));
    std::sort(all.begin(), all.end());
    for (int j = 0; j < 10; ++j)
    {
      EXPECT_EQ(table.neighbors(i)[j], all[j].second);
      EXPECT_NEAR(pcl_ecs::sqrDistance(*cloud, i, static_cast<std::size_t>(table.neighbors(i)[j])), all[j].first, 1e-6f);
    }
  }
}

TEST(Neighborhood, RefusesTooFewPoints)
{
  auto cloud = gridPlane(3, 1.0);  // 9 points
  pcl::search::KdTree<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  pcl_ecs::NeighborhoodTable table;
  EXPECT_EQ(pcl_ecs::computeNeighborhoods(*cloud, tree, 9, 1, table), pcl_ecs::Status::TooFewPoints);
  EXPECT_EQ(pcl_ecs::computeNeighborhoods(*cloud, tree, 8, 1, table), pcl_ecs::Status::Ok);
}

TEST(Neighborhood, SameResultWithOneOrTwoThreads)
{
  auto cloud = fibonacciSphere(3000, 1.0, 0.01, 9);
  pcl::search::KdTree<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  pcl_ecs::NeighborhoodTable a, b;
  pcl_ecs::computeNeighborhoods(*cloud, tree, 16, 1, a);
  pcl_ecs::computeNeighborhoods(*cloud, tree, 16, 2, b);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    ASSERT_TRUE(std::equal(a.neighbors(i), a.neighbors(i) + a.k, b.neighbors(i))) << "row " << i;
}

// A cloud that stresses the blocked search: a dense patch, exact duplicates, an integer grid (many
// equal distances), far outliers, in shuffled order. The table must equal brute force exactly:
// the k smallest (distance, index) pairs, whatever the back end and the thread count.
TEST(Neighborhood, ExactOnTiesDuplicatesAndOutliers)
{
  Rng rng(17);
  auto cloud = std::make_shared<Cloud>();
  for (int i = 0; i < 2500; ++i)
    cloud->push_back(toPoint({rng.uniform(0, 1), rng.uniform(0, 1), 0.01 * rng.uniform()}));
  for (int i = 0; i < 300; ++i)
    cloud->push_back((*cloud)[static_cast<std::size_t>(i * 7)]);
  for (int x = 0; x < 12; ++x)
    for (int y = 0; y < 12; ++y)
      cloud->push_back(toPoint({3.0 + 0.05 * x, 0.05 * y, 0.0}));
  for (int i = 0; i < 150; ++i)
    cloud->push_back(toPoint({rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(-50, 50)}));
  for (std::size_t i = cloud->size() - 1; i > 0; --i)
    std::swap((*cloud)[i], (*cloud)[static_cast<std::size_t>(rng.uniform(0, 1) * static_cast<double>(i + 1)) % (i + 1)]);
  const int k = 16;
  std::vector<std::vector<std::pair<float, int>>> expected(cloud->size());
  for (std::size_t i = 0; i < cloud->size(); ++i)
    expected[i] = bruteForceNearest(*cloud, i, k);
  pcl_ecs::NanoflannSearch nano;
  nano.setInputCloud(cloud);
  pcl::search::KdTree<pcl::PointXYZ> flann;
  flann.setInputCloud(cloud);
  pcl_ecs::BoxTreeSearch boxes;
  boxes.setInputCloud(cloud);
  for (const pcl::search::Search<pcl::PointXYZ>* search :
       {static_cast<const pcl::search::Search<pcl::PointXYZ>*>(&nano),
        static_cast<const pcl::search::Search<pcl::PointXYZ>*>(&flann),
        static_cast<const pcl::search::Search<pcl::PointXYZ>*>(&boxes)})
    for (int threads : {1, 2})
    {
      pcl_ecs::NeighborhoodTable table;
      ASSERT_EQ(pcl_ecs::computeNeighborhoods(*cloud, *search, k, threads, table), pcl_ecs::Status::Ok);
      std::size_t wrong = 0;
      for (std::size_t i = 0; i < cloud->size(); ++i)
        for (int j = 0; j < k; ++j)
          if (table.neighbors(i)[j] != expected[i][static_cast<std::size_t>(j)].second ||
              std::abs(pcl_ecs::sqrDistance(*cloud, i, static_cast<std::size_t>(table.neighbors(i)[j])) -
                       expected[i][static_cast<std::size_t>(j)].first) >
                  1e-6f * std::max(1.f, expected[i][static_cast<std::size_t>(j)].first))
            ++wrong;
      EXPECT_EQ(wrong, 0u) << search->getName() << ", " << threads << " threads";
    }
}

// Far from the origin (coordinates ~4000, spacing ~0.0015, a float's step there 2.4e-4: the
// points sit on a coarse lattice, with many equal distances) the blocked search stays exact.
TEST(Neighborhood, ExactFarFromTheOrigin)
{
  Rng rng(29);
  auto cloud = std::make_shared<Cloud>();
  for (int i = 0; i < 6000; ++i)
    cloud->push_back(toPoint({4000.0 + rng.uniform(0, 0.12), -3000.0 + rng.uniform(0, 0.12), 2000.0 + 0.0005 * rng.uniform()}));
  for (int i = 0; i < 50; ++i)
    cloud->push_back(toPoint({4000.0 + rng.uniform(-30, 30), -3000.0 + rng.uniform(-30, 30), 2000.0 + rng.uniform(-30, 30)}));
  const int k = 16;
  pcl_ecs::NanoflannSearch nano;
  nano.setInputCloud(cloud);
  pcl_ecs::NeighborhoodTable table;
  ASSERT_EQ(pcl_ecs::computeNeighborhoods(*cloud, nano, k, 2, table), pcl_ecs::Status::Ok);
  std::size_t wrong = 0;
  for (std::size_t i = 0; i < cloud->size(); ++i)
  {
    const auto all = bruteForceNearest(*cloud, i, k);
    for (int j = 0; j < k; ++j)
      wrong += table.neighbors(i)[j] != all[static_cast<std::size_t>(j)].second ? 1 : 0;
  }
  EXPECT_EQ(wrong, 0u);
}

// In Hilbert order (as the filter keeps its points) consecutive points share one gathered ball;
// where the density jumps a point's k-th neighbour lies past that ball and the point is answered
// by a query of its own. Strips of 1x, 4x and 16x the spacing, a dense cluster and lone points,
// on the box tree the filter uses: the table must still equal brute force exactly.
TEST(Neighborhood, ExactInHilbertOrderWhereTheDensityJumps)
{
  Rng rng(41);
  Cloud raw;
  for (int strip = 0; strip < 3; ++strip)
  {
    const double h = 0.01 * std::pow(4.0, strip);
    for (double x = 0; x < 0.6; x += h)
      for (double y = 0.6 * strip; y < 0.6 * strip + 0.6; y += h)
        raw.push_back(toPoint({x + 0.2 * h * rng.uniform(), y + 0.2 * h * rng.uniform(), 0.001 * rng.uniform()}));
  }
  for (int i = 0; i < 800; ++i)
    raw.push_back(toPoint({0.3 + 0.01 * rng.uniform(), 1.5 + 0.01 * rng.uniform(), 0.0}));
  for (int i = 0; i < 40; ++i)
    raw.push_back(toPoint({rng.uniform(-2, 3), rng.uniform(-2, 3), rng.uniform(-1, 1)}));
  std::vector<int> ids(raw.size());
  for (std::size_t i = 0; i < ids.size(); ++i)
    ids[i] = static_cast<int>(i);
  auto position = [&](int i) { return raw[static_cast<std::size_t>(i)].getVector3fMap().cast<double>().eval(); };
  pcl_ecs::sortBySpatialCode(ids, position, Eigen::Vector3d(-2, -2, -1), Eigen::Vector3d(3, 3, 1));
  auto cloud = std::make_shared<Cloud>();
  for (const int i : ids)
    cloud->push_back(raw[static_cast<std::size_t>(i)]);
  const int k = 16;
  pcl_ecs::BoxTreeSearch boxes;
  boxes.setInputCloud(cloud);
  std::vector<std::vector<std::pair<float, int>>> expected(cloud->size());
  for (std::size_t i = 0; i < cloud->size(); ++i)
    expected[i] = bruteForceNearest(*cloud, i, k);
  // Both builds of the inner loops (the AVX2 one runs only where the CPU has it).
  for (const int run : {0, 1, 2, 3})
  {
    const bool avx2 = run >= 2;
    const int threads = 1 + run % 2;
    pcl_ecs::detail::allowAvx2(avx2);
    pcl_ecs::NeighborhoodTable table;
    ASSERT_EQ(pcl_ecs::computeNeighborhoods(*cloud, boxes, k, threads, table), pcl_ecs::Status::Ok);
    pcl_ecs::detail::allowAvx2(true);
    std::size_t wrong = 0;
    for (std::size_t i = 0; i < cloud->size(); ++i)
    {
      const auto& all = expected[i];
      for (int j = 0; j < k; ++j)
        wrong += table.neighbors(i)[j] != all[static_cast<std::size_t>(j)].second ||
                         pcl_ecs::sqrDistance(*cloud, i, static_cast<std::size_t>(table.neighbors(i)[j])) !=
                             all[static_cast<std::size_t>(j)].first
                     ? 1
                     : 0;
    }
    EXPECT_EQ(wrong, 0u) << threads << " threads, AVX2 " << (avx2 && pcl_ecs::detail::useAvx2());
  }
}
