#include <pcl_ecs/neighborhood.h>

#include "synthetic_shapes.h"

#include <algorithm>

#include <gtest/gtest.h>
#include <pcl/search/kdtree.h>

using namespace pcl_ecs_test;

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
      EXPECT_NEAR(table.sqrDistances(i)[j], all[j].first, 1e-6f);
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
  EXPECT_EQ(a.indices, b.indices);
  EXPECT_EQ(a.sqr_distances, b.sqr_distances);
}
