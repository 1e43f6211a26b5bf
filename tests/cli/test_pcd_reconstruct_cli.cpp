// Integration tests of pcd_reconstruct and pcd_simplify --mesh: meshes written in the three
// formats and read back, topology of the results, every refusal with its exit code and no output.
#include "cli_fixture.h"

#include <pcl_ecs/surface/cocone.h>

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <pcl/PolygonMesh.h>
#include <pcl/conversions.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

namespace fs = std::filesystem;
using pcl_ecs::surface::analyzeTopology;
using pcl_ecs::surface::MeshTopology;
using pcl_ecs::surface::Triangle;

namespace
{
const std::string kReconstruct = PCD_RECONSTRUCT_PATH;
const std::string kSimplify = PCD_SIMPLIFY_PATH;
const std::string kShared = PCL_ECS_SHARED_DATA_DIR;

using pcl_ecs_test::RunResult;
using pcl_ecs_test::slurp;

class MeshCli : public pcl_ecs_test::TempDirTest
{
protected:
  RunResult run(const std::string& tool, const std::string& args) const { return runTool(tool, args); }

  /// A sphere of n points as an .xyz file.
  std::string sphereXyz(const std::string& name, int n) const
  {
    std::mt19937_64 rng(5);
    std::normal_distribution<double> g;
    std::ofstream out(path(name));
    out.precision(17);
    for (int i = 0; i < n; ++i)
    {
      double x = g(rng), y = g(rng), z = g(rng);
      const double r = std::sqrt(x * x + y * y + z * z);
      out << 3 * x / r << ' ' << 3 * y / r << ' ' << 3 * z / r << '\n';
    }
    return path(name);
  }

  void expectOnly(const std::set<std::string>& names) const
  {
    for (const auto& e : fs::directory_iterator(dir_))
      EXPECT_TRUE(names.count(e.path().filename().string())) << "left behind: " << e.path();
  }
};

MeshTopology plyTopology(const std::string& file, std::size_t* vertices = nullptr)
{
  pcl::PolygonMesh mesh;
  EXPECT_EQ(pcl::io::loadPLYFile(file, mesh), 0) << file;
  std::vector<Triangle> tris;
  for (const auto& p : mesh.polygons)
    tris.push_back({static_cast<std::uint32_t>(p.vertices.at(0)), static_cast<std::uint32_t>(p.vertices.at(1)),
                    static_cast<std::uint32_t>(p.vertices.at(2))});
  const std::size_t n = mesh.cloud.width * mesh.cloud.height;
  if (vertices)
    *vertices = n;
  return analyzeTopology(n, tris);
}
}  // namespace

TEST_F(MeshCli, SphereInEveryFormat)
{
  const std::string in = sphereXyz("s.xyz", 2000);
  RunResult r = run(kReconstruct, in + " " + path("s.ply") + " --stats " + path("s.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("closed manifold"), std::string::npos) << r.out;
  std::size_t v = 0;
  const MeshTopology t = plyTopology(path("s.ply"), &v);
  EXPECT_EQ(v, 2000u);
  EXPECT_TRUE(t.isClosedManifold());
  EXPECT_EQ(t.triangles, 2 * 2000u - 4);
  const auto j = nlohmann::json::parse(slurp(path("s.json")));
  EXPECT_EQ(j["topology"]["boundary_loops"], 0);
  EXPECT_EQ(j["topology"]["nonmanifold_edges"], 0);
  EXPECT_EQ(j["counts"]["triangles"], 3996);
  EXPECT_TRUE(j["timings_s"].contains("delaunay"));

  ASSERT_EQ(run(kReconstruct, in + " " + path("s.obj")).code, 0);
  const std::string obj = slurp(path("s.obj"));
  std::size_t vs = 0, fs_ = 0;
  std::istringstream lines(obj);
  for (std::string line; std::getline(lines, line);)
  {
    vs += line.rfind("v ", 0) == 0;
    fs_ += line.rfind("f ", 0) == 0;
  }
  EXPECT_EQ(vs, 2000u);
  EXPECT_EQ(fs_, 3996u);

  ASSERT_EQ(run(kReconstruct, in + " " + path("s.vtk") + " --quiet").code, 0);
  const std::string vtk = slurp(path("s.vtk"));
  EXPECT_NE(vtk.find("POINTS 2000 double"), std::string::npos);
  EXPECT_NE(vtk.find("POLYGONS 3996 15984"), std::string::npos);
}

TEST_F(MeshCli, RefusalsLeaveNothingBehind)
{
  // Coplanar points: input error.
  {
    std::ofstream out(path("flat.xyz"));
    for (int i = 0; i < 10; ++i)
      for (int j = 0; j < 10; ++j)
        out << i << ' ' << j << " 0\n";
  }
  RunResult r = run(kReconstruct, path("flat.xyz") + " " + path("m.ply"));
  EXPECT_EQ(r.code, 3);
  EXPECT_NE(r.err.find("coplanar"), std::string::npos) << r.err;
  // Missing input.
  r = run(kReconstruct, path("missing.pcd") + " " + path("m.ply"));
  EXPECT_EQ(r.code, 3);
  // Unknown mesh format, unknown flag, bad value.
  const std::string in = sphereXyz("s.xyz", 300);
  r = run(kReconstruct, in + " " + path("m.stl"));
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(".ply, .obj or .vtk"), std::string::npos) << r.err;
  EXPECT_EQ(run(kReconstruct, in + " " + path("m.ply") + " --bogus").code, 2);
  r = run(kReconstruct, in + " " + path("m.ply") + " --cocone-angle 95");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("cocone angle"), std::string::npos) << r.err;
  EXPECT_EQ(run(kReconstruct, in + " " + path("m.ply") + " --fill-holes x").code, 2);
  // Output directory missing.
  r = run(kReconstruct, in + " " + path("nodir/m.ply"));
  EXPECT_EQ(r.code, 4);
  // pcd_simplify refuses a bad --mesh name before doing any work.
  r = run(kSimplify, in + " " + path("o.pcd") + " --mesh " + path("m.stl"));
  EXPECT_EQ(r.code, 2);
  expectOnly({"flat.xyz", "s.xyz"});
  // --help answers.
  r = run(kReconstruct, "--help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("--max-edge-ratio"), std::string::npos);
}

TEST_F(MeshCli, SimplifyThenMeshTheBunny)
{
  const std::string in = kShared + "/bunny.pcd";
  if (!fs::exists(in))
    GTEST_SKIP() << "shared data missing";
  RunResult r = run(kSimplify, in + " " + path("b.pcd") + " --mesh " + path("b.ply") + " --stats " + path("b.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  std::size_t v = 0;
  const MeshTopology t = plyTopology(path("b.ply"), &v);
  EXPECT_TRUE(t.isManifold());
  EXPECT_TRUE(t.consistently_oriented);
  EXPECT_EQ(t.nonmanifold_edges, 0u);
  const auto j = nlohmann::json::parse(slurp(path("b.json")));
  const std::size_t simplified = j["counts"]["output_points"];
  // Most simplified points are on the surface; the loops are the bunny's own openings plus the
  // places the simplified sampling is too thin for Cocone.
  EXPECT_GE(static_cast<double>(v), 0.95 * static_cast<double>(simplified));
  EXPECT_LE(t.boundary_loops, 20u);
  EXPECT_EQ(j["mesh"]["topology"]["boundary_loops"], t.boundary_loops);

  // --watertight closes it.
  r = run(kReconstruct, path("b.pcd") + " " + path("w.ply") + " --watertight");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("closed manifold"), std::string::npos) << r.out;
  EXPECT_TRUE(plyTopology(path("w.ply")).isClosedManifold());
}

TEST_F(MeshCli, SimplifiedClosedShapesAreMeshedWithoutHoles)
{
  // Spot (a sphere's topology) and fertility (genus 4) simplified to 10% and meshed as a user
  // would: closed, with the shape's Euler characteristic. Without the relaxation the adaptive
  // sampling leaves loops along the seams between large and small balls, longer than a few edges;
  // the hole filling closes them within the gap guard, and with loops of at most 8 edges closed
  // (the earlier default) the same points leave holes.
  for (const auto& [shape, euler] : {std::pair<std::string, long>{"spot", 2}, {"fertility", -6}})
  {
    const std::string in = kShared + "/" + shape + "_scan.pcd";
    if (!fs::exists(in))
      GTEST_SKIP() << "shared data missing";
    const std::string pcd = path(shape + ".pcd"), ply = path(shape + ".ply"), few = path(shape + "8.ply");
    RunResult r = run(kSimplify, in + " " + pcd + " --target-ratio 0.1 --mesh " + ply);
    ASSERT_EQ(r.code, 0) << r.err;
    const MeshTopology t = plyTopology(ply);
    EXPECT_TRUE(t.isClosedManifold()) << shape << ": boundary edges " << t.boundary_edges << " of " << t.edges;
    EXPECT_EQ(t.euler_characteristic, euler) << shape;
    EXPECT_EQ(t.components, 1u) << shape;
    // The points before the relaxation (METHOD.md 4), less even: closed by the filling, and not with
    // loops of at most 8 edges closed.
    const std::string plain = path(shape + "_plain.pcd"), plain_ply = path(shape + "_plain.ply");
    r = run(kSimplify, in + " " + plain + " --target-ratio 0.1 --no-relax --mesh " + plain_ply);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(plyTopology(plain_ply).isClosedManifold()) << shape;
    r = run(kReconstruct, plain + " " + few + " --fill-holes 8");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_GT(plyTopology(few).boundary_edges, 0u) << shape;
  }
}
