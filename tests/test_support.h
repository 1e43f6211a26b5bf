// test_support.h — the neighbourhood table and normals of a test cloud, built the way the core
// builds them, for the per-stage tests.
#pragma once

#include <pcl_ecs/neighborhood.h>
#include <pcl_ecs/stages/normals.h>

#include <pcl/search/kdtree.h>

namespace pcl_ecs_test
{

inline pcl_ecs::NeighborhoodTable makeTable(const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud, int k)
{
  pcl::search::KdTree<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  pcl_ecs::NeighborhoodTable table;
  pcl_ecs::computeNeighborhoods(*cloud, tree, k, 2, table);
  return table;
}

inline pcl_ecs::NormalList makeNormals(const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud,
                                       const pcl_ecs::NeighborhoodTable& table)
{
  pcl_ecs::NormalList normals;
  pcl_ecs::estimateNormals(*cloud, table, 2, normals);
  return normals;
}

}  // namespace pcl_ecs_test
