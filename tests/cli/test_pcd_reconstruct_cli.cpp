// Integration tests of pcd_reconstruct and pcd_simplify --mesh: meshes written in the three
// formats and read back, topology of the results, every refusal with its exit code and no output.
#include "cli_fixture.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/surface/cocone.h>

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <tuple>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <pcl/PolygonMesh.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
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

  /// `pcd_simplify --target-ratio RATIO --mesh` of the shared `shape`'s scan; returns the mesh's
  /// path, empty when the shared data is missing.
  std::string simplifiedMesh(const std::string& shape, const std::string& ratio) const
  {
    const std::string in = kShared + "/" + shape + "_scan.pcd";
    if (!fs::exists(in))
      return {};
    const std::string ply = path(shape + ratio + ".ply");
    const RunResult r = run(kSimplify, in + " " + path(shape + ratio + ".pcd") + " --target-ratio " + ratio + " --mesh " + ply);
    EXPECT_EQ(r.code, 0) << r.err;
    return ply;
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

/// A closed 2-manifold in one piece with Euler characteristic `euler`.
void expectClosedPiece(const std::string& ply, long euler)
{
  const MeshTopology t = plyTopology(ply);
  EXPECT_TRUE(t.isClosedManifold()) << ply << ": boundary edges " << t.boundary_edges << " of " << t.edges;
  EXPECT_EQ(t.euler_characteristic, euler) << ply;
  EXPECT_EQ(t.components, 1u) << ply;
}

/// The signed volume of each component (through shared edges) of a PLY mesh: positive when its
/// triangles face out of what it encloses (for a closed component).
std::vector<double> componentVolumes(const std::string& file)
{
  pcl::PolygonMesh mesh;
  EXPECT_EQ(pcl::io::loadPLYFile(file, mesh), 0) << file;
  pcl::PointCloud<pcl::PointXYZ> v;
  pcl_ecs::io::fromCloud(mesh.cloud, v);  // x, y, z stored as doubles
  const std::size_t f = mesh.polygons.size();
  std::vector<std::size_t> parent(f);
  for (std::size_t i = 0; i < f; ++i)
    parent[i] = i;
  auto find = [&](std::size_t x) {
    while (parent[x] != x)
      x = parent[x] = parent[parent[x]];
    return x;
  };
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::size_t> first_at;
  for (std::size_t t = 0; t < f; ++t)
    for (int k = 0; k < 3; ++k)
    {
      std::uint32_t a = mesh.polygons[t].vertices.at(k), b = mesh.polygons[t].vertices.at((k + 1) % 3);
      if (a > b)
        std::swap(a, b);
      const auto [it, fresh] = first_at.emplace(std::make_pair(a, b), t);
      if (!fresh)
        parent[find(t)] = find(it->second);
    }
  std::map<std::size_t, double> volume;
  for (std::size_t t = 0; t < f; ++t)
  {
    const auto& ix = mesh.polygons[t].vertices;
    const Eigen::Vector3d a = v[ix[0]].getVector3fMap().cast<double>(), b = v[ix[1]].getVector3fMap().cast<double>(),
                          c = v[ix[2]].getVector3fMap().cast<double>();
    volume[find(t)] += a.dot(b.cross(c)) / 6;
  }
  std::vector<double> out;
  for (const auto& [root, vol] : volume)
    out.push_back(vol);
  return out;
}

/// The volume a PLY mesh encloses: the sum of its components' signed volumes.
double enclosedVolume(const std::string& file)
{
  double volume = 0.0;
  for (const double v : componentVolumes(file))
    volume += v;
  return volume;
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
  // pcd_simplify gives Cocone each point's ball radius: it refuses the triangles between balls that
  // do not overlap (pcd_reconstruct, on the points alone, knows no radius).
  EXPECT_GT(j["mesh"]["counts"]["apart_triangles"].get<std::size_t>(), 0u);

  // --watertight closes it.
  r = run(kReconstruct, path("b.pcd") + " " + path("w.ply") + " --watertight --stats " + path("w.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("closed manifold"), std::string::npos) << r.out;
  EXPECT_TRUE(plyTopology(path("w.ply")).isClosedManifold());
  EXPECT_EQ(nlohmann::json::parse(slurp(path("w.json")))["counts"]["apart_triangles"].get<std::size_t>(), 0u);
}

TEST_F(MeshCli, RadiiWrittenBySimplifyGiveReconstructTheSameMesh)
{
  // pcd_simplify --radii writes each point's ball radius (0 for the feature points); pcd_reconstruct
  // reads the field and makes the mesh pcd_simplify --mesh makes, byte for byte.
  const std::string in = kShared + "/bunny.pcd";
  if (!fs::exists(in))
    GTEST_SKIP() << "shared data missing";
  RunResult r = run(kSimplify, in + " " + path("s.pcd") + " --target-ratio 0.1 --radii --labels --mesh " +
                                   path("a.ply") + " --stats " + path("a.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  pcl::PCLPointCloud2 cloud;
  ASSERT_EQ(pcl::io::loadPCDFile(path("s.pcd"), cloud), 0);
  const int ri = pcl_ecs::io::fieldIndex(cloud.fields, "ecs_radius"), li = pcl_ecs::io::fieldIndex(cloud.fields, "ecs_label");
  ASSERT_GE(ri, 0);
  ASSERT_GE(li, 0);
  std::size_t features = 0, balls = 0;
  for (std::size_t i = 0; i < cloud.width; ++i)
  {
    const std::uint8_t* rec = cloud.data.data() + i * cloud.point_step;
    float radius = 0;
    std::memcpy(&radius, rec + cloud.fields[ri].offset, sizeof radius);
    const std::uint8_t label = rec[cloud.fields[li].offset];
    EXPECT_TRUE(label == 1 ? radius == 0.0f : radius >= 0.0f) << i;
    features += label == 1 ? 1 : 0;
    balls += label == 2 && radius > 0.0f ? 1 : 0;
  }
  EXPECT_GT(features, 0u);
  EXPECT_GT(balls, cloud.width / 2);
  r = run(kReconstruct, path("s.pcd") + " " + path("b.ply") + " --stats " + path("b.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(slurp(path("a.ply")), slurp(path("b.ply")));
  const auto a = nlohmann::json::parse(slurp(path("a.json")))["mesh"]["counts"];
  const auto b = nlohmann::json::parse(slurp(path("b.json")))["counts"];
  EXPECT_GT(a["apart_triangles"].get<std::size_t>(), 0u);
  EXPECT_EQ(a["apart_triangles"], b["apart_triangles"]);
  // The same radii as a LAS extra dimension: the same mesh (counted: LAS holds the coordinates as
  // integers of its scale), and without them another one.
  r = run(kSimplify, in + " " + path("s.las") + " --target-ratio 0.1 --radii --quiet");
  ASSERT_EQ(r.code, 0) << r.err;
  r = run(kReconstruct, path("s.las") + " " + path("c.ply") + " --stats " + path("c.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(slurp(path("c.json")))["counts"], b);
  r = run(kSimplify, in + " " + path("n.las") + " --target-ratio 0.1 --quiet");
  ASSERT_EQ(r.code, 0) << r.err;
  r = run(kReconstruct, path("n.las") + " " + path("d.ply") + " --stats " + path("d.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(nlohmann::json::parse(slurp(path("d.json")))["counts"]["apart_triangles"].get<std::size_t>(), 0u);
  // Out of core there is one output and no radii.
  r = run(kSimplify, in + " " + path("t.pcd") + " --stream --radii");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--radii"), std::string::npos) << r.err;
}

TEST_F(MeshCli, TunnelsOpenAgainstTheScan)
{
  // The turbine at 10%: pcd_simplify --mesh --tunnels opens the ten bolt holes its mesh caps
  // without (χ −20, not 0), giving Cocone its input as the scan; pcd_reconstruct does the same with
  // --support (each scan point given to its nearest sample). --tunnels without --support, and
  // --support without --tunnels, are usage errors that write nothing.
  const std::string in = kShared + "/turbine_scan.pcd";
  if (!fs::exists(in))
    GTEST_SKIP() << "shared data missing";
  RunResult r = run(kSimplify, in + " " + path("t.pcd") + " --target-ratio 0.1 --radii --quiet --mesh " + path("a.ply") +
                                   " --stats " + path("a.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  auto mesh = nlohmann::json::parse(slurp(path("a.json")))["mesh"];
  EXPECT_EQ(mesh["topology"]["euler_characteristic"].get<long>(), 0);
  EXPECT_EQ(mesh["counts"]["opened_tunnels"].get<std::size_t>(), 0u);
  EXPECT_FALSE(mesh["parameters"]["open_tunnels"].get<bool>());
  r = run(kSimplify, in + " " + path("t.pcd") + " --target-ratio 0.1 --radii --quiet --mesh " + path("b.ply") +
                         " --tunnels --stats " + path("b.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  mesh = nlohmann::json::parse(slurp(path("b.json")))["mesh"];
  EXPECT_EQ(mesh["topology"]["euler_characteristic"].get<long>(), -20);
  EXPECT_EQ(mesh["counts"]["opened_tunnels"].get<std::size_t>(), 10u);
  EXPECT_TRUE(plyTopology(path("b.ply")).isClosedManifold());
  r = run(kReconstruct, path("t.pcd") + " " + path("c.ply") + " --tunnels --support " + in + " --stats " + path("c.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  const auto c = nlohmann::json::parse(slurp(path("c.json")));
  EXPECT_EQ(c["topology"]["euler_characteristic"].get<long>(), -20);
  EXPECT_TRUE(c["parameters"]["open_tunnels"].get<bool>());
  r = run(kReconstruct, path("t.pcd") + " " + path("d.ply") + " --tunnels");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--tunnels needs --support"), std::string::npos) << r.err;
  r = run(kReconstruct, path("t.pcd") + " " + path("d.ply") + " --support " + in);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--support is read by --tunnels only"), std::string::npos) << r.err;
  r = run(kReconstruct, path("t.pcd") + " " + path("d.ply") + " --tunnels --support " + path("missing.pcd"));
  EXPECT_EQ(r.code, 3);
  EXPECT_FALSE(fs::exists(path("d.ply")));
}

TEST_F(MeshCli, ARadiusFieldThatHoldsNoRadiusIsRefused)
{
  // ecs_radius is 0 (unknown) or a positive, finite radius; anything else is a damaged file:
  // refused with the point and its value, nothing written.
  const std::string in = kShared + "/bunny.pcd";
  if (!fs::exists(in))
    GTEST_SKIP() << "shared data missing";
  RunResult r = run(kSimplify, in + " " + path("s.pcd") + " --target-ratio 0.1 --radii");
  ASSERT_EQ(r.code, 0) << r.err;
  pcl::PCLPointCloud2 cloud;
  ASSERT_EQ(pcl::io::loadPCDFile(path("s.pcd"), cloud), 0);
  const int ri = pcl_ecs::io::fieldIndex(cloud.fields, "ecs_radius");
  ASSERT_GE(ri, 0);
  for (const float bad : {-1.0f, std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()})
  {
    pcl::PCLPointCloud2 damaged = cloud;
    std::memcpy(damaged.data.data() + 7 * damaged.point_step + damaged.fields[ri].offset, &bad, sizeof bad);
    ASSERT_EQ(pcl::io::savePCDFile(path("d.pcd"), damaged, Eigen::Vector4f::Zero(), Eigen::Quaternionf::Identity(), true), 0);
    r = run(kReconstruct, path("d.pcd") + " " + path("d.ply"));
    EXPECT_EQ(r.code, 3) << bad << ": " << r.err;
    EXPECT_NE(r.err.find("point 7 has ecs_radius"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(path("d.ply")));
  }
  r = run(kReconstruct, path("s.pcd") + " " + path("s.ply"));
  EXPECT_EQ(r.code, 0) << r.err;
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
    const std::string ply = simplifiedMesh(shape, "0.1");
    if (ply.empty())
      GTEST_SKIP() << "shared data missing";
    expectClosedPiece(ply, euler);
    // The points before the relaxation (METHOD.md 4), less even: closed by the filling, and not with
    // loops of at most 8 edges closed.
    const std::string in = kShared + "/" + shape + "_scan.pcd", few = path(shape + "8.ply");
    const std::string plain = path(shape + "_plain.pcd"), plain_ply = path(shape + "_plain.ply");
    RunResult r = run(kSimplify, in + " " + plain + " --target-ratio 0.1 --no-relax --mesh " + plain_ply);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(plyTopology(plain_ply).isClosedManifold()) << shape;
    r = run(kReconstruct, plain + " " + few + " --fill-holes 8");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_GT(plyTopology(few).boundary_edges, 0u) << shape;
  }
}

TEST_F(MeshCli, CadPartsSimplifiedMeshClosedAndFacingOut)
{
  // Simplified and meshed as a user would. At 10%, the pinion (one hole through it), the joint
  // (genus 2) and the spool: closed, one piece, the part's Euler characteristic, facing out
  // (positive volume; the spool's last slit, where the walk's two fronts meet, is closed because
  // it is narrower than the sampling: isSlit). The spool at 10% and 3% encloses the reference's
  // volume within 3% (a mesh partly inside out encloses less: with a breadth-first walk from one
  // seed the spool at 10% enclosed −7% of it, with 3.3% of its edges open along the slits where the
  // two orientations met; best first from one seed, the spool at 3% −43%), and at 3% at most 0.2%
  // of its edges are open.
  const std::string reference = kShared + "/spool_mesh.ply";
  if (!fs::exists(reference))
    GTEST_SKIP() << "shared data missing";
  const double enclosed = enclosedVolume(reference);
  ASSERT_GT(enclosed, 0.0);
  for (const auto& [shape, euler] : {std::pair<std::string, long>{"pinion", 0}, {"joint", -2}, {"spool", 2}})
  {
    const std::string ply = simplifiedMesh(shape, "0.1");
    if (ply.empty())
      GTEST_SKIP() << "shared data missing";
    expectClosedPiece(ply, euler);
    const std::vector<double> volumes = componentVolumes(ply);
    ASSERT_EQ(volumes.size(), 1u) << shape;
    EXPECT_GT(volumes[0], 0) << shape << " faces in";
    if (shape == "spool")
      EXPECT_NEAR(volumes[0], enclosed, 0.03 * enclosed) << "spool at 10%";
  }
  const std::string ply = simplifiedMesh("spool", "0.03");
  if (ply.empty())
    GTEST_SKIP() << "shared data missing";
  const MeshTopology t = plyTopology(ply);
  EXPECT_TRUE(t.isManifold());
  EXPECT_LE(static_cast<double>(t.boundary_edges), 0.002 * static_cast<double>(t.edges));
  EXPECT_NEAR(enclosedVolume(ply), enclosed, 0.03 * enclosed) << "spool at 3%";
}

TEST_F(MeshCli, ClosedShapesAtThreePercentKeepTheirGenus)
{
  // The closed runs of docs/SURFACE.md that meet the whole bar at 3% (the spot's is in
  // CutOffPiecesFaceOutAndJoinTheSurface) and the part at 10%: closed, one piece, the reference's
  // Euler characteristic (the elephant genus 3: its thin bridge, three samples around, is kept
  // (kThinPartGirth); the fertility genus 4, the pinion 1, the joint 2, the part 0), facing out.
  for (const auto& [shape, ratio, euler] : {std::tuple<std::string, std::string, long>{"elephant", "0.03", -4},
                                            {"fertility", "0.03", -6}, {"pinion", "0.03", 0}, {"joint", "0.03", -2},
                                            {"part", "0.03", 2}, {"part", "0.1", 2}})
  {
    const std::string ply = simplifiedMesh(shape, ratio);
    if (ply.empty())
      GTEST_SKIP() << "shared data missing";
    expectClosedPiece(ply, euler);
    EXPECT_GT(enclosedVolume(ply), 0.0) << ply << " faces in";
  }
}

TEST_F(MeshCli, CutOffPiecesFaceOutAndJoinTheSurface)
{
  // Where the simplified sampling is thin (a leg's end, an ear), a walk can cross a fold and go on
  // with the other side up, and the manifold clean-up then leaves a piece inside out. The walk
  // crosses the flattest edges first, each piece left apart takes the orientation of the surface
  // around it, and a piece whose loop faces a loop of the surface is joined back by a band: every
  // piece faces out and the surface is whole. (The steps themselves: test_cocone.cpp.)
  const std::string spot = kShared + "/spot_scan.pcd", elephant = kShared + "/elephant_scan.pcd";
  if (!fs::exists(spot) || !fs::exists(elephant))
    GTEST_SKIP() << "shared data missing";
  // Spot at 3%: every piece is closed and faces out, at most two pieces.
  RunResult r = run(kSimplify, spot + " " + path("spot.pcd") + " --target-ratio 0.03 --mesh " + path("spot.ply"));
  ASSERT_EQ(r.code, 0) << r.err;
  const MeshTopology ts = plyTopology(path("spot.ply"));
  EXPECT_TRUE(ts.isClosedManifold());
  EXPECT_LE(ts.components, 2u);
  const std::vector<double> volumes = componentVolumes(path("spot.ply"));
  ASSERT_EQ(volumes.size(), ts.components);
  for (double vol : volumes)
    EXPECT_GT(vol, 0) << "a piece of the spot faces in";
  // Elephant at 10% (genus 3): one closed surface with the shape's Euler characteristic.
  r = run(kSimplify, elephant + " " + path("el.pcd") + " --target-ratio 0.1");
  ASSERT_EQ(r.code, 0) << r.err;
  r = run(kReconstruct, path("el.pcd") + " " + path("el.ply"));
  ASSERT_EQ(r.code, 0) << r.err;
  const MeshTopology te = plyTopology(path("el.ply"));
  EXPECT_TRUE(te.isClosedManifold());
  EXPECT_EQ(te.components, 1u);
  EXPECT_EQ(te.euler_characteristic, -4);
  for (double vol : componentVolumes(path("el.ply")))
    EXPECT_GT(vol, 0);
}
