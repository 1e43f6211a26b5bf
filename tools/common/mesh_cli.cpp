// mesh_cli.cpp — see mesh_cli.h.
#include "common/mesh_cli.h"

#include "common/cli.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/io/cloud_io.h>
#include <pcl_ecs/surface/cocone_reconstruction.h>

#include <pcl/conversions.h>
#include <pcl/point_types.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

namespace pcl_ecs
{
namespace tools
{
namespace
{
constexpr double kDeg = 3.14159265358979323846 / 180.0;

bool hasField(const pcl::PCLPointCloud2& c, const std::string& name)
{
  for (const auto& f : c.fields)
    if (f.name == name)
      return true;
  return false;
}
}  // namespace

bool applyCoconeFlag(const std::string& flag, const std::function<std::string()>& value,
                     surface::CoconeParameters& p)
{
  if (flag == "--cocone-angle")
    p.cocone_angle = parseDoubleFlag(flag, value()) * kDeg;
  else if (flag == "--no-boundaries")
    p.detect_boundaries = false;
  else if (flag == "--boundary-ratio")
    p.boundary_ratio = parseDoubleFlag(flag, value());
  else if (flag == "--boundary-angle")
    p.boundary_normal_angle = parseDoubleFlag(flag, value()) * kDeg;
  else if (flag == "--sharp-angle")
    p.sharp_edge_angle = parseDoubleFlag(flag, value()) * kDeg;
  else if (flag == "--no-prune")
    p.prune = false;
  else if (flag == "--max-edge-ratio")
    p.max_edge_ratio = parseDoubleFlag(flag, value());
  else if (flag == "--fill-holes")
    p.fill_hole_edges = static_cast<std::size_t>(parseUnsignedFlag(flag, value()));
  else if (flag == "--watertight")
    p.watertight = true;
  else if (flag == "--tunnels")
    p.open_tunnels = true;
  else if (flag == "--min-component")
    p.min_component_triangles = static_cast<std::size_t>(parseUnsignedFlag(flag, value()));
  else
    return false;
  const std::string why = p.validate();
  if (!why.empty())
    throw UsageError(flag + ": " + why);
  return true;
}

std::string coconeFlagsHelp()
{
  const surface::CoconeParameters d;
  std::ostringstream s;
  s << "Cocone (defaults are the authors'):\n"
    << "  --cocone-angle DEG  θ: the cocone holds the directions within θ of the tangent plane\n"
    << "                      (default " << d.cocone_angle / kDeg << ")\n"
    << "  --no-boundaries     do not detect boundary samples (closed surfaces only)\n"
    << "  --boundary-ratio R  ratio condition r_p/h_p <= R of a regular sample (default " << d.boundary_ratio << ")\n"
    << "  --boundary-angle DEG  normal condition between cocone neighbours (default "
    << d.boundary_normal_angle / kDeg << ")\n"
    << "  --sharp-angle DEG   prune triangles at edges with a gap above this (default " << d.sharp_edge_angle / kDeg << ")\n"
    << "  --no-prune          skip the pruning of sharp edges\n"
    << "  --max-edge-ratio R  refuse triangles longer than R × the local spacing, 0 = off (default "
    << d.max_edge_ratio << ")\n"
    << "  --fill-holes N      close boundary loops of at most N edges, then cut out handles only three\n"
    << "                      edges around; 0 = neither (default " << d.fill_hole_edges << ")\n"
    << "  --watertight        seal every remaining boundary loop: a closed surface for closed objects\n"
    << "  --tunnels           open the tunnels the cocones capped on both faces (a bolt hole a few\n"
    << "                      samples across), judged against the scan the cloud was simplified from:\n"
    << "                      pcd_simplify --mesh uses its input, pcd_reconstruct needs --support;\n"
    << "                      off by default (it reads every scan point: a few ms on 150k points)\n"
    << "  --min-component N   drop pieces of fewer than N triangles (default " << d.min_component_triangles << ")\n";
  return s.str();
}

surface::ScanSupport scanSupport(const pcl::PCLPointCloud2& scan, std::vector<std::int64_t> sample_of)
{
  pcl::PointCloud<pcl::PointXYZ> xyz;
  pcl_ecs::io::fromCloud(scan, xyz);
  return pcl_ecs::scanSupport(xyz, std::move(sample_of));
}

MeshRun meshCloud(const pcl::PCLPointCloud2& cloud, const surface::CoconeParameters& params,
                  const std::vector<double>& sample_radius, const surface::ScanSupport& support)
{
  MeshRun run;
  pcl::PointCloud<pcl::PointXYZ> xyz;
  pcl_ecs::io::fromCloud(cloud, xyz);
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(xyz.size());
  for (const auto& p : xyz)
    pts.emplace_back(p.x, p.y, p.z);
  run.result = surface::coconeReconstruct(pts, params, sample_radius, support);
  if (!run.result.ok())
    return run;
  run.topology = surface::analyzeTopology(pts.size(), run.result.triangles);
  run.mesh = surface::compactMesh(pts, run.result.triangles);
  if (hasField(cloud, "rgb") || hasField(cloud, "rgba"))
  {
    pcl::PointCloud<pcl::PointXYZRGB> rgb;
    pcl_ecs::io::fromCloud(cloud, rgb);
    run.colors.rgb.reserve(run.mesh.source_index.size());
    for (std::uint32_t i : run.mesh.source_index)
      run.colors.rgb.push_back({rgb[i].r, rgb[i].g, rgb[i].b});
  }
  return run;
}

void writeMeshFile(const std::string& path, surface::MeshFormat format, const MeshRun& run)
{
  std::ofstream out(path, std::ios::binary);
  if (!out)
    throw io::FileError(path + ": cannot create the file");
  try
  {
    surface::writeMesh(out, format, run.mesh, run.colors.rgb.empty() ? nullptr : &run.colors);
  }
  catch (const std::exception& e)
  {
    throw io::FileError(path + ": " + e.what());
  }
}

nlohmann::json meshStatsJson(const MeshRun& run, const surface::CoconeParameters& p)
{
  const auto& s = run.result.stats;
  const auto& t = run.topology;
  nlohmann::json j;
  j["parameters"] = {{"cocone_angle_deg", p.cocone_angle / kDeg},
                     {"detect_boundaries", p.detect_boundaries},
                     {"boundary_ratio", p.boundary_ratio},
                     {"boundary_normal_angle_deg", p.boundary_normal_angle / kDeg},
                     {"sharp_edge_angle_deg", p.sharp_edge_angle / kDeg},
                     {"prune", p.prune},
                     {"max_edge_ratio", p.max_edge_ratio},
                     {"fill_hole_edges", p.fill_hole_edges},
                     {"min_component_triangles", p.min_component_triangles},
                     {"watertight", p.watertight},
                     {"open_tunnels", p.open_tunnels}};
  j["counts"] = {{"input_points", s.input_points},
                 {"non_finite_points", s.non_finite_points},
                 {"duplicate_points", s.duplicate_points},
                 {"delaunay_vertices", s.vertices},
                 {"delaunay_cells", s.delaunay_cells},
                 {"hull_vertices", s.hull_vertices},
                 {"boundary_samples", s.boundary_samples},
                 {"gap_triangles", s.gap_triangles},
                 {"apart_triangles", s.apart_triangles},
                 {"candidate_triangles", s.candidate_triangles},
                 {"pruned_triangles", s.pruned_triangles},
                 {"extracted_triangles", s.extracted_triangles},
                 {"filled_triangles", s.filled_triangles},
                 {"reoriented_pieces", s.reoriented_pieces},
                 {"stitched_loops", s.stitched_loops},
                 {"narrowed_loops", s.narrowed_loops},
                 {"removed_handles", s.removed_handles},
                 {"dropped_layers", s.dropped_layers},
                 {"stitched_triangles", s.stitched_triangles},
                 {"flipped_edges", s.flipped_edges},
                 {"cleanup_removed_triangles", s.cleanup_removed_triangles},
                 {"sealed_loops", s.sealed_loops},
                 {"opened_tunnels", s.opened_tunnels},
                 {"tunnel_triangles", s.tunnel_triangles},
                 {"triangles", s.triangles},
                 {"used_vertices", s.used_vertices}};
  j["topology"] = {{"edges", t.edges},
                   {"boundary_edges", t.boundary_edges},
                   {"boundary_loops", t.boundary_loops},
                   {"components", t.components},
                   {"nonmanifold_edges", t.nonmanifold_edges},
                   {"nonmanifold_vertices", t.nonmanifold_vertices},
                   {"consistently_oriented", t.consistently_oriented},
                   {"euler_characteristic", t.euler_characteristic},
                   {"closed_manifold", t.isClosedManifold()}};
  j["timings_s"] = {{"delaunay", s.time_delaunay}, {"poles", s.time_poles},     {"cocone", s.time_cocone},
                    {"prune", s.time_prune},       {"extract", s.time_extract}, {"cleanup", s.time_cleanup},
                    {"total", s.time_total}};
  return j;
}

std::string meshSummaryLine(const MeshRun& run)
{
  const auto& t = run.topology;
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "%zu vertices, %zu triangles; %s, %zu boundary loop(s), %zu component(s), %zu non-manifold edges; %.2f s",
                run.mesh.vertices.size(), run.mesh.triangles.size(),
                t.isClosedManifold() ? "closed manifold" : (t.isManifold() ? "manifold" : "NOT manifold"),
                t.boundary_loops, t.components, t.nonmanifold_edges, run.result.stats.time_total);
  return buf;
}

}  // namespace tools
}  // namespace pcl_ecs
