// Replaces pcl::VoxelGrid by the filter in a three-line pipeline and checks it did something.
#include <pcl_ecs/feature_aware_cover_simplify.h>
#include <pcl_ecs/surface/cocone_reconstruction.h>

#include <cmath>
#include <cstdio>

int main()
{
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZRGB>>();
  for (int i = 0; i < 100; ++i)
    for (int j = 0; j < 100; ++j)
    {
      pcl::PointXYZRGB p;
      p.x = i * 0.01f;
      p.y = j * 0.01f;
      p.z = 0.1f * std::sin(i * 0.05f);
      p.r = 200;
      cloud->push_back(p);
    }
  pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZRGB> ecs;
  ecs.setInputCloud(cloud);
  pcl::PointCloud<pcl::PointXYZRGB> out;
  ecs.filter(out);
  std::printf("consumer: %zu -> %zu points\n", cloud->size(), out.size());
  if (!(out.size() > 0 && out.size() < cloud->size() && out[0].r == 200))
    return 1;
  // The simplified sheet meshed with Cocone, where GreedyProjectionTriangulation would stand.
  pcl_ecs::Cocone<pcl::PointXYZRGB> cocone;
  cocone.setInputCloud(std::make_shared<pcl::PointCloud<pcl::PointXYZRGB>>(out));
  pcl::PolygonMesh mesh;
  cocone.reconstruct(mesh);
  std::printf("consumer: %zu triangles\n", mesh.polygons.size());
  return mesh.polygons.empty() ? 1 : 0;
}
