// pcd_make_scan — large test scans: dense samples of a mesh as several overlapping simulated range
// scans (density falls with distance and obliquity, so it varies across the surface), with range
// noise, written chunk by chunk with the streaming PCD writer (any size, constant memory).
#include "common/cli.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/io/record_stream.h>
#include <pcl_ecs/version.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <random>
#include <vector>

#include <pcl/PolygonMesh.h>
#include <pcl/conversions.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

using namespace pcl_ecs;
using namespace pcl_ecs::tools;

namespace
{
const char* kUsage = R"(Usage: pcd_make_scan MESH OUTPUT --points N [options]

Writes N points sampled on MESH (PLY) as S simulated range scans from scanner
positions spread around the model: a scan sees a face with density proportional to
|cos(incidence)| / distance², so the point density varies across the surface and the scans overlap.
OUTPUT is .pcd (fields x y z intensity, float, intensity = |cos(incidence)|, and scan, uint8) or
.las / .laz (LAS 1.2 point format 0: intensity = |cos(incidence)| × 65535, point_source_id = the
scan, scale the finest power of ten that holds the box). Memory does not grow with N: the points
are written in chunks of 65536.

Options:
  --points N     number of points (required; 1 to 2^40)
  --scans S      number of scans, 1-255 (default 6)
  --noise F      range noise, standard deviation as a fraction of the mesh's bounding-box
                 diagonal (default 2e-4)
  --scale F      multiply the coordinates by F (default 1)
  --offset X Y Z add (X, Y, Z) after scaling (default 0 0 0; e.g. UTM-sized coordinates)
  --seed N       random seed (default 1); same seed, same file
  --quiet        no progress
  --help

Example:
  pcd_make_scan bunny_mesh.ply big.pcd --points 50000000 --scans 8
  pcd_make_scan bunny_mesh.ply big.laz --points 50000000 --scale 100 --offset 512000 4100000 200
)";

struct Tri
{
  Eigen::Vector3d a, b, c, n;
  double area;
};
}  // namespace

int run(int argc, char** argv)
{
  std::vector<std::string> pos;
  std::uint64_t points = 0, seed = 1;
  int scans = 6;
  double noise = 2e-4, scale = 1.0;
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  bool quiet = false;
  for (ArgWalker args(argc, argv); args.next();)
  {
    const std::string& a = args.flag();
    auto value = [&]() { return args.value(); };
    if (a == "--help" || a == "-h")
    {
      std::cout << kUsage;
      return kExitOk;
    }
    if (a == "--points")
      points = parseUnsignedFlag(a, value());
    else if (a == "--scans")
      scans = static_cast<int>(parseIntFlag(a, value()));
    else if (a == "--noise")
      noise = parseDoubleFlag(a, value());
    else if (a == "--scale")
      scale = parseDoubleFlag(a, value());
    else if (a == "--offset")
      for (int k = 0; k < 3; ++k)
        offset[k] = parseDoubleFlag(a, value());
    else if (a == "--seed")
      seed = parseUnsignedFlag(a, value());
    else if (a == "--quiet")
      quiet = true;
    else if (a.size() > 1 && a[0] == '-')
      throw UsageError("unknown option '" + a + "' (see --help)");
    else
      pos.push_back(a);
  }
  if (pos.size() != 2)
    throw UsageError("expected MESH and OUTPUT (see --help)");
  if (points == 0 || points > (1ull << 40))
    throw UsageError("--points: give a count from 1 to 2^40");
  if (scans < 1 || scans > 255)
    throw UsageError("--scans: must be 1 to 255");
  if (!(noise >= 0.0 && noise < 0.1))
    throw UsageError("--noise: must be in [0, 0.1)");
  if (!(scale > 0.0) || !std::isfinite(scale) || !offset.allFinite())
    throw UsageError("--scale / --offset: must be finite (scale > 0)");
  const io::Format format = io::formatFromPath(pos[1]);
  const bool las = format == io::Format::Las || format == io::Format::Laz;
  if (format != io::Format::Pcd && !las)
    throw UsageError(pos[1] + ": the output must be .pcd, .las or .laz");
  const std::string why = io::checkWritable(pos[1]);
  if (!why.empty())
    throw ToolError(kExitOutput, pos[1] + ": " + why);

  std::error_code ec;
  if (!std::filesystem::is_regular_file(pos[0], ec))
    throw ToolError(kExitInput, pos[0] + ": no such file");
  pcl::PolygonMesh mesh;
  if (pcl::io::loadPLYFile(pos[0], mesh) < 0 || mesh.polygons.empty())
    throw ToolError(kExitInput, pos[0] + ": cannot read a mesh with faces from it");
  pcl::PointCloud<pcl::PointXYZ> v;
  pcl_ecs::io::fromCloud(mesh.cloud, v);
  std::vector<Tri> tris;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const auto& poly : mesh.polygons)
    for (std::size_t k = 1; k + 1 < poly.vertices.size(); ++k)
    {
      const auto bad = [&](auto idx) { return idx < 0 || static_cast<std::size_t>(idx) >= v.size(); };
      if (bad(poly.vertices[0]) || bad(poly.vertices[k]) || bad(poly.vertices[k + 1]))
        throw ToolError(kExitInput, pos[0] + ": a face refers to a vertex that does not exist");
      Tri t;
      t.a = v[poly.vertices[0]].getVector3fMap().cast<double>();
      t.b = v[poly.vertices[k]].getVector3fMap().cast<double>();
      t.c = v[poly.vertices[k + 1]].getVector3fMap().cast<double>();
      const Eigen::Vector3d cr = (t.b - t.a).cross(t.c - t.a);
      t.area = 0.5 * cr.norm();
      if (!(t.area > 0.0) || !std::isfinite(t.area))
        continue;
      t.n = cr.normalized();
      for (const auto* p : {&t.a, &t.b, &t.c})
      {
        lo = lo.cwiseMin(*p);
        hi = hi.cwiseMax(*p);
      }
      tris.push_back(t);
    }
  if (tris.empty())
    throw ToolError(kExitInput, pos[0] + ": the mesh has no faces of non-zero area");
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double diag = (hi - lo).norm();

  // Scanner positions on a Fibonacci sphere of radius 1.5 L around the model.
  std::vector<Eigen::Vector3d> scanner(static_cast<std::size_t>(scans));
  for (int s = 0; s < scans; ++s)
  {
    const double z = scans == 1 ? 0.5 : 1.0 - 2.0 * (s + 0.5) / scans;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = s * 2.399963229728653;
    scanner[static_cast<std::size_t>(s)] = centre + 1.5 * diag * Eigen::Vector3d(r * std::cos(phi), r * std::sin(phi), z);
  }
  // Per scan: the cumulative weights |cos| / d² × area of every face.
  std::vector<std::vector<double>> cumulative(static_cast<std::size_t>(scans));
  for (int s = 0; s < scans; ++s)
  {
    auto& cum = cumulative[static_cast<std::size_t>(s)];
    cum.resize(tris.size());
    double total = 0.0;
    for (std::size_t t = 0; t < tris.size(); ++t)
    {
      const Eigen::Vector3d mid = (tris[t].a + tris[t].b + tris[t].c) / 3.0;
      const Eigen::Vector3d d = scanner[static_cast<std::size_t>(s)] - mid;
      const double dist2 = d.squaredNorm();
      total += tris[t].area * std::abs(tris[t].n.dot(d)) / std::sqrt(dist2) / dist2;
      cum[t] = total;
    }
  }

  // PCD: x y z intensity as float, scan as uint8 (17 bytes); LAS: x y z as double, intensity and
  // point_source_id as uint16 (28 bytes).
  using Field = pcl::PCLPointField;
  io::PcdHeader layout;
  const auto add = [&](const char* name, std::uint8_t type, std::uint32_t size) {
    Field f;
    f.name = name;
    f.offset = layout.point_step;
    f.datatype = type;
    f.count = 1;
    layout.fields.push_back(f);
    layout.point_step += size;
  };
  for (const char* a : {"x", "y", "z"})
    add(a, las ? Field::FLOAT64 : Field::FLOAT32, las ? 8 : 4);
  add("intensity", las ? Field::UINT16 : Field::FLOAT32, las ? 2 : 4);
  add(las ? "point_source_id" : "scan", las ? Field::UINT16 : Field::UINT8, las ? 2 : 1);
  const std::uint32_t step = layout.point_step;
  // A box that holds every point (the mesh's, widened by 20 standard deviations of the noise).
  const double margin = 20.0 * noise * diag * scale + 1e-9 * diag * scale;
  std::array<double, 3> box_lo, box_hi;
  for (int a = 0; a < 3; ++a)
  {
    box_lo[a] = lo[a] * scale + offset[a] - margin;
    box_hi[a] = hi[a] * scale + offset[a] + margin;
  }
  io::RecordSink writer(pos[1], layout, nullptr, box_lo, box_hi);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  const std::size_t chunk = 1 << 16;
  std::vector<std::uint8_t> buf(chunk * step);
  std::uint64_t done = 0;
  while (done < points)
  {
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(chunk, points - done));
    for (std::size_t i = 0; i < n; ++i)
    {
      const std::uint64_t g = done + i;
      const int s = static_cast<int>(g % static_cast<std::uint64_t>(scans));
      const auto& cum = cumulative[static_cast<std::size_t>(s)];
      const double r = uni(rng) * cum.back();
      const std::size_t t = std::min<std::size_t>(tris.size() - 1, static_cast<std::size_t>(
          std::upper_bound(cum.begin(), cum.end(), r) - cum.begin()));
      double u = uni(rng), w = uni(rng);
      if (u + w > 1.0)
      {
        u = 1.0 - u;
        w = 1.0 - w;
      }
      const Tri& tri = tris[t];
      Eigen::Vector3d p = tri.a + u * (tri.b - tri.a) + w * (tri.c - tri.a);
      const Eigen::Vector3d ray = (p - scanner[static_cast<std::size_t>(s)]).normalized();
      const double incidence = std::abs(tri.n.dot(ray));
      p += noise * diag * gauss(rng) * ray;
      p = p * scale + offset;
      std::uint8_t* rec = buf.data() + i * step;
      if (las)
      {
        const double xyz[3] = {p.x(), p.y(), p.z()};
        const std::uint16_t v[2] = {static_cast<std::uint16_t>(std::lround(incidence * 65535.0)),
                                    static_cast<std::uint16_t>(s)};
        std::memcpy(rec, xyz, 24);
        std::memcpy(rec + 24, v, 4);
      }
      else
      {
        const float v[4] = {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()),
                            static_cast<float>(incidence)};
        std::memcpy(rec, v, 16);
        rec[16] = static_cast<std::uint8_t>(s);
      }
    }
    writer.append(buf.data(), n);
    done += n;
    if (!quiet && (done % (1u << 22) < chunk || done == points))
      std::fprintf(stderr, "pcd_make_scan: %llu / %llu points\n", static_cast<unsigned long long>(done),
                   static_cast<unsigned long long>(points));
  }
  writer.commit();
  if (!quiet)
    std::printf("%s: %llu points, %d scans, noise %.3g L\n", pos[1].c_str(), static_cast<unsigned long long>(points),
                scans, noise);
  return kExitOk;
}

int main(int argc, char** argv)
{
  pcl_ecs::io::removeTemporariesOnSignal();  // an interrupted run leaves no temporary file
  return runToolMain("pcd_make_scan", [&] {
    try
    {
      return run(argc, argv);
    }
    catch (const io::FileError& e)
    {
      throw ToolError(kExitOutput, e.what());
    }
  });
}
