// pcd_reconstruct — the Cocone surface of any cloud, written as PLY, OBJ or VTK.
#include "common/cli.h"
#include "common/mesh_cli.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/io/cloud_io.h>
#include <pcl_ecs/version.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <nlohmann/json.hpp>

namespace fs = std::filesystem;
using namespace pcl_ecs;
using namespace pcl_ecs::tools;

namespace
{

const char* kUsage = R"(Usage: pcd_reconstruct INPUT OUTPUT [options]

Triangulates a point cloud with the Cocone algorithm (Amenta, Choi, Dey, Leekha): the Delaunay
triangles whose dual Voronoi edges cross the cocones of their vertices, pruned at sharp edges and
walked into an oriented 2-manifold. Open surfaces keep their openings (Dey-Giesen boundary
detection). No normals needed. Meant for clouds of a few hundred to a few million points, e.g. the
output of pcd_simplify; on a dense scan, simplify first.

INPUT   .pcd, .ply, .las, .laz or .xyz/.txt/.pts/.asc (x y z, and colour if present). A field
        or LAS extra dimension 'ecs_radius' (pcd_simplify --radii: each point's ball radius, 0
        for a point kept as it is) is used as pcd_simplify --mesh uses it: triangles between
        balls far from overlapping are refused, a point of radius 0 judged by its nearest
        neighbour's ball; a negative or non-finite value is refused as a damaged file (exit 3).
OUTPUT  .ply (binary), .obj or .vtk, by extension; colour is written to PLY and VTK when the
        input has it. Only the vertices the triangles use are written. Written to a temporary
        file beside OUTPUT and renamed into place on success.

)";

const char* kOptions = R"(
Scan:
  --support FILE      the scan INPUT was simplified from (any format INPUT takes), for --tunnels:
                      each of its points is given to the nearest point of INPUT

Output:
  --stats FILE.json   counts, topology (boundary loops, components, non-manifold edges, Euler
                      characteristic) and time per stage
  --quiet             print nothing but errors
  --help, --version

Exit codes: 0 success; 1 internal error; 2 usage error; 3 input error (unreadable, fewer than 4
distinct points, points on one plane or line, no surface found); 4 output error.

Examples:
  pcd_reconstruct small.pcd small.ply
  pcd_simplify scan.pcd small.pcd --mesh small.ply       # simplify and mesh in one go
  pcd_reconstruct small.pcd small.ply --tunnels --support scan.pcd   # open capped bolt holes
  pcd_reconstruct range_view.pcd view.obj --stats view.json
)";

int run(int argc, char** argv)
{
  surface::CoconeParameters params;
  std::vector<std::string> pos;
  std::string stats, support_path;
  bool quiet = false;
  for (ArgWalker args(argc, argv); args.next();)
  {
    const std::string& a = args.flag();
    auto value = [&]() { return args.value(); };
    if (printedHelpOrVersion(a, "pcd_reconstruct", [] { return kUsage + coconeFlagsHelp() + kOptions; }))
      return kExitOk;
    if (applyCoconeFlag(a, value, params))
      continue;
    if (a == "--stats")
      stats = value();
    else if (a == "--support")
      support_path = value();
    else if (a == "--quiet" || a == "-q")
      quiet = true;
    else if (a.size() > 1 && a[0] == '-')
      throw UsageError("unknown option '" + a + "' (see --help)");
    else
      pos.push_back(a);
  }
  if (pos.size() != 2)
    throw UsageError("expected INPUT and OUTPUT, got " + std::to_string(pos.size()) + " file name(s) (see --help)");
  if (params.open_tunnels && support_path.empty())
    throw UsageError("--tunnels needs --support FILE: the scan the cloud was simplified from");
  if (!support_path.empty() && !params.open_tunnels)
    throw UsageError("--support is read by --tunnels only; give both or neither");
  const std::string &input_path = pos[0], &output = pos[1];
  surface::MeshFormat format;
  try
  {
    format = surface::meshFormatFromPath(output);
  }
  catch (const std::invalid_argument& e)
  {
    throw UsageError(e.what());
  }
  if (!stats.empty() && fs::path(stats).extension() != ".json")
    throw UsageError(stats + ": --stats writes JSON; give it a .json name");
  std::error_code ec;
  for (const std::string* out : std::vector<const std::string*>{&output, &stats})
  {
    if (out->empty())
      continue;
    if (fs::weakly_canonical(input_path, ec) == fs::weakly_canonical(*out, ec))
      throw UsageError(*out + ": is the input file; choose another output name");
    const std::string why = io::checkWritable(*out);
    if (!why.empty())
      throw ToolError(kExitOutput, *out + ": " + why);
  }

  pcl::PCLPointCloud2 cloud;
  try
  {
    io::readCloud(input_path, cloud);
  }
  catch (const std::exception& e)
  {
    throw ToolError(kExitInput, e.what());
  }
  std::vector<double> radius;
  if (io::fieldIndex(cloud.fields, "ecs_radius") >= 0)
  {
    pcl::PCLPointField f;
    f.name = "ecs_radius";
    f.offset = 0;
    f.datatype = pcl::PCLPointField::FLOAT64;
    f.count = 1;
    radius.resize(static_cast<std::size_t>(cloud.width) * cloud.height);
    io::convertRecords(cloud, {f}, sizeof(double), reinterpret_cast<std::uint8_t*>(radius.data()),
                       Eigen::Vector3d::Zero());
    for (std::size_t i = 0; i < radius.size(); ++i)
      if (!(radius[i] >= 0.0) || std::isinf(radius[i]))
      {
        std::ostringstream os;
        os << input_path << ": point " << i << " has ecs_radius " << radius[i]
           << ": a ball radius is 0 (a point kept as it is) or positive and finite";
        throw ToolError(kExitInput, os.str());
      }
  }
  pcl::PCLPointCloud2 scan;
  if (!support_path.empty())
  {
    try
    {
      io::readCloud(support_path, scan);
    }
    catch (const std::exception& e)
    {
      throw ToolError(kExitInput, e.what());
    }
  }
  const MeshRun mesh =
      meshCloud(cloud, params, radius, support_path.empty() ? surface::ScanSupport{} : scanSupport(scan));
  if (!mesh.result.ok())
    throw ToolError(kExitInput, input_path + ": " + mesh.result.error);

  std::vector<std::unique_ptr<io::AtomicOutput>> outputs;
  try
  {
    outputs.push_back(std::make_unique<io::AtomicOutput>(output));
    writeMeshFile(outputs.back()->tempPath(), format, mesh);
    if (!stats.empty())
    {
      outputs.push_back(std::make_unique<io::AtomicOutput>(stats));
      nlohmann::json j = meshStatsJson(mesh, params);
      j["tool"] = "pcd_reconstruct";
      j["version"] = PCL_ECS_VERSION_STRING;
      j["input"] = input_path;
      j["output"] = output;
      std::ofstream js(outputs.back()->tempPath());
      js << j.dump(2) << "\n";
      js.flush();
      if (!js)
        throw io::FileError(stats + ": write error");
    }
    for (auto& o : outputs)
      o->commit();
  }
  catch (const io::FileError& e)
  {
    throw ToolError(kExitOutput, e.what());
  }
  if (!quiet)
    std::printf("%s: %s\n", output.c_str(), meshSummaryLine(mesh).c_str());
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv)
{
  pcl_ecs::io::removeTemporariesOnSignal();  // an interrupted run leaves no temporary file
  return runToolMain("pcd_reconstruct", [&] { return run(argc, argv); });
}
