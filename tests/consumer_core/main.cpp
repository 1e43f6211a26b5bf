// The filter alone, on a wavy sheet: it must keep fewer points than it was given.
#include <pcl_ecs/feature_aware_cover_simplify.h>

#include <cmath>
#include <cstdio>

int main()
{
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 100; ++j)
      cloud->push_back(pcl::PointXYZ(i * 0.01f, j * 0.01f, 0.1f * std::sin(i * 0.05f)));
  pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ> ecs;
  ecs.setInputCloud(cloud);
  pcl::PointCloud<pcl::PointXYZ> out;
  ecs.filter(out);
  std::printf("core_consumer: %zu -> %zu points\n", cloud->size(), out.size());
  return out.size() > 0 && out.size() < cloud->size() ? 0 : 1;
}
