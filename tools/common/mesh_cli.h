// mesh_cli.h — what pcd_reconstruct and pcd_simplify --mesh share: the Cocone flags, meshing a
// cloud read from a file (colour carried over), writing the mesh, its JSON summary.
#pragma once

#include <pcl_ecs/surface/cocone.h>
#include <pcl_ecs/surface/mesh_io.h>

#include <pcl/PCLPointCloud2.h>

#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace pcl_ecs
{
namespace tools
{

/** \brief If `flag` is a Cocone flag, read its value through `value()`, store it and return true.
 * Throws UsageError for a bad value. */
bool applyCoconeFlag(const std::string& flag, const std::function<std::string()>& value,
                     surface::CoconeParameters& params);

/** \brief The --help text of the Cocone flags, with the defaults. */
std::string coconeFlagsHelp();

/** \brief A mesh made from a cloud. */
struct MeshRun
{
  surface::CoconeResult result;
  surface::MeshTopology topology;
  surface::CompactMesh mesh;
  surface::VertexColors colors;  ///< filled when the cloud has rgb / rgba
};

/** \brief The scan a cloud was simplified from as surface::coconeReconstruct takes it: its x, y, z
 * and, per scan point, the sample standing for it (Result::input_to_output; empty: the nearest). */
surface::ScanSupport scanSupport(const pcl::PCLPointCloud2& scan, std::vector<std::int64_t> sample_of = {});

/** \brief Mesh the points of `cloud` (x, y, z; rgb carried over when present); `sample_radius`,
 * per point or empty, and `support`, as surface::coconeReconstruct takes them (a simplified cloud's
 * pointRadii; the scan it came from, used with CoconeParameters::open_tunnels). */
MeshRun meshCloud(const pcl::PCLPointCloud2& cloud, const surface::CoconeParameters& params,
                  const std::vector<double>& sample_radius = {}, const surface::ScanSupport& support = {});

/** \brief Write `run` to `path` in `format`. Throws io::FileError. */
void writeMeshFile(const std::string& path, surface::MeshFormat format, const MeshRun& run);

/** \brief Counts, topology and time per stage. */
nlohmann::json meshStatsJson(const MeshRun& run, const surface::CoconeParameters& params);

/** \brief One line: vertices, triangles, boundary loops, components, non-manifold counts. */
std::string meshSummaryLine(const MeshRun& run);

}  // namespace tools
}  // namespace pcl_ecs
