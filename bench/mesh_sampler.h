// mesh_sampler.h — dense, seeded, area-uniform samples of a triangle mesh (for benchmarks and
// large test scans), with optional Gaussian noise along the face normal.
#pragma once

#include <pcl_ecs/io/cloud_convert.h>
#include <cmath>
#include <cstdint>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <pcl/PolygonMesh.h>
#include <pcl/conversions.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace pcl_ecs_bench
{

struct Triangles
{
  std::vector<Eigen::Vector3d> a, b, c;
  std::vector<double> cumulative_area;
};

inline Triangles loadTriangles(const std::string& ply)
{
  pcl::PolygonMesh mesh;
  if (pcl::io::loadPLYFile(ply, mesh) < 0)
    throw std::runtime_error(ply + ": cannot read the mesh");
  pcl::PointCloud<pcl::PointXYZ> v;
  pcl_ecs::io::fromCloud(mesh.cloud, v);
  Triangles t;
  double total = 0.0;
  for (const auto& poly : mesh.polygons)
    for (std::size_t k = 1; k + 1 < poly.vertices.size(); ++k)  // fan-triangulate polygons
    {
      const Eigen::Vector3d a = v[poly.vertices[0]].getVector3fMap().cast<double>();
      const Eigen::Vector3d b = v[poly.vertices[k]].getVector3fMap().cast<double>();
      const Eigen::Vector3d c = v[poly.vertices[k + 1]].getVector3fMap().cast<double>();
      total += 0.5 * (b - a).cross(c - a).norm();
      t.a.push_back(a);
      t.b.push_back(b);
      t.c.push_back(c);
      t.cumulative_area.push_back(total);
    }
  if (t.a.empty())
    throw std::runtime_error(ply + ": the mesh has no faces");
  return t;
}

/// n points uniform by area; noise is the standard deviation along the face normal.
inline pcl::PointCloud<pcl::PointXYZ>::Ptr sampleTriangles(const Triangles& t, std::size_t n,
                                                           double noise, std::uint64_t seed)
{
  std::mt19937_64 rng(seed);
  auto uni = [&]() { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
  std::normal_distribution<double> gauss(0.0, 1.0);
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->reserve(n);
  const double total = t.cumulative_area.back();
  for (std::size_t i = 0; i < n; ++i)
  {
    const double pick = uni() * total;
    const std::size_t f = static_cast<std::size_t>(
        std::upper_bound(t.cumulative_area.begin(), t.cumulative_area.end(), pick) - t.cumulative_area.begin());
    const std::size_t k = std::min(f, t.a.size() - 1);
    double u = uni(), w = uni();
    if (u + w > 1.0)
    {
      u = 1.0 - u;
      w = 1.0 - w;
    }
    Eigen::Vector3d p = t.a[k] + u * (t.b[k] - t.a[k]) + w * (t.c[k] - t.a[k]);
    if (noise > 0.0)
    {
      const Eigen::Vector3d nrm = (t.b[k] - t.a[k]).cross(t.c[k] - t.a[k]).normalized();
      p += noise * gauss(rng) * nrm;
    }
    cloud->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
  }
  return cloud;
}

}  // namespace pcl_ecs_bench
