// pcl_ecs_eval — the quality of a simplified cloud against its original (and a reference mesh):
// surface deviation, coverage, Hausdorff, distance to the mesh, distance from sharp mesh edges.
#include "common/cli.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/eval/quality_metrics.h>
#include <pcl_ecs/io/cloud_io.h>
#include <pcl_ecs/version.h>

#include <cstdio>
#include <iostream>

#include <nlohmann/json.hpp>
#include <pcl/conversions.h>
#include <pcl/console/print.h>
#include <pcl/io/vtk_lib_io.h>

using namespace pcl_ecs;

namespace
{
const char* kUsage = R"(Usage: pcl_ecs_eval ORIGINAL SIMPLIFIED [--mesh REFERENCE] [--json]

Every distance is a fraction of L, the diagonal of ORIGINAL's bounding box:
  surface deviation  for each original point, the distance to the plane fitted to its 8 nearest
                     simplified points (RMS and 99th percentile)
  coverage           for each original point, the distance to the nearest simplified point
                     (mean and max): holes show here
  tangent offset     for each original point, how far its nearest simplified point lies off the
                     surface there: the offset along the point's normal (PCA of its 16 nearest
                     original points), RMS and 99th percentile
  hausdorff          symmetric Hausdorff distance between the two clouds
  with --mesh (PLY, OBJ, VTK, STL):
  mesh distance      for each simplified point, the distance to the mesh (mean, p99, max)
  sharp edges        for points sampled every 5e-4 L along the mesh edges whose faces meet at more
                     than 40 degrees, the distance to the nearest simplified point (mean, p90)

Exit codes: 0 ok, 2 usage, 3 an input cannot be read.
)";

pcl::PointCloud<pcl::PointXYZ> load(const std::string& path)
{
  pcl::PCLPointCloud2 blob;
  io::readCloud(path, blob);
  pcl::PointCloud<pcl::PointXYZ> all, finite;
  pcl_ecs::io::fromCloud(blob, all);
  for (const auto& p : all)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
      finite.push_back(p);
  return finite;
}

eval::TriangleMesh loadMesh(const std::string& path)
{
  pcl::PolygonMesh pm;
  if (pcl::io::loadPolygonFile(path, pm) <= 0 || pm.polygons.empty())
    throw io::FileError(path + ": cannot read a mesh from it");
  pcl::PointCloud<pcl::PointXYZ> v;
  pcl_ecs::io::fromCloud(pm.cloud, v);
  eval::TriangleMesh m;
  for (const auto& p : v)
    m.vertices.push_back(p.getVector3fMap().cast<double>());
  for (const auto& poly : pm.polygons)
    for (std::size_t k = 1; k + 1 < poly.vertices.size(); ++k)
      m.triangles.emplace_back(static_cast<int>(poly.vertices[0]), static_cast<int>(poly.vertices[k]),
                               static_cast<int>(poly.vertices[k + 1]));
  return m;
}
}  // namespace

int main(int argc, char** argv)
{
  std::vector<std::string> pos;
  std::string mesh_path;
  bool json = false;
  tools::ArgWalker args(argc, argv);
  while (true)
  {
    try
    {
      if (!args.next())
        break;
    }
    catch (const tools::UsageError& e)
    {
      std::fprintf(stderr, "pcl_ecs_eval: %s\n", e.what());
      return tools::kExitUsage;
    }
    const std::string a = args.flag();
    if (tools::printedHelpOrVersion(a, "pcl_ecs_eval", [] { return std::string(kUsage); }))
      return tools::kExitOk;
    if (a == "--json")
      json = true;
    else if (a == "--mesh")
    {
      try
      {
        mesh_path = args.value();
      }
      catch (const tools::UsageError& e)
      {
        std::fprintf(stderr, "pcl_ecs_eval: %s\n", e.what());
        return tools::kExitUsage;
      }
    }
    else if (!a.empty() && a[0] == '-')
    {
      std::fprintf(stderr, "pcl_ecs_eval: unknown option '%s' (see --help)\n", a.c_str());
      return tools::kExitUsage;
    }
    else
      pos.push_back(a);
  }
  if (pos.size() != 2)
  {
    std::fprintf(stderr, "pcl_ecs_eval: expected ORIGINAL and SIMPLIFIED (see --help)\n");
    return tools::kExitUsage;
  }
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  eval::QualityMetrics m;
  try
  {
    const auto original = load(pos[0]);
    const auto simplified = load(pos[1]);
    eval::TriangleMesh mesh;
    if (!mesh_path.empty())
      mesh = loadMesh(mesh_path);
    if (!eval::evaluateQuality(original, simplified, mesh_path.empty() ? nullptr : &mesh, m))
    {
      std::fprintf(stderr, "pcl_ecs_eval: %s or %s has no finite points (or zero extent)\n", pos[0].c_str(), pos[1].c_str());
      return tools::kExitInput;
    }
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "pcl_ecs_eval: %s\n", e.what());
    return tools::kExitInput;
  }
  nlohmann::json j = {{"original", pos[0]},
                      {"simplified", pos[1]},
                      {"bbox_diagonal", m.bbox_diagonal},
                      {"original_points", m.original_points},
                      {"simplified_points", m.simplified_points},
                      {"surface_rms", m.surface_rms},
                      {"surface_p99", m.surface_p99},
                      {"coverage_mean", m.coverage_mean},
                      {"coverage_max", m.coverage_max},
                      {"tangent_rms", m.tangent_rms},
                      {"tangent_p99", m.tangent_p99},
                      {"hausdorff", m.hausdorff}};
  if (m.has_mesh)
  {
    j["mesh"] = mesh_path;
    j["mesh_mean"] = m.mesh_mean;
    j["mesh_p99"] = m.mesh_p99;
    j["mesh_max"] = m.mesh_max;
    j["sharp_edge_samples"] = m.sharp_edge_samples;
    j["edge_mean"] = m.edge_mean;
    j["edge_p90"] = m.edge_p90;
  }
  if (json)
    std::cout << j.dump(2) << "\n";
  else
    for (const auto& [k, v] : j.items())
      std::cout << k << ": " << v << "\n";
  return tools::kExitOk;
}
