// bench_peers — the head-to-head: pcl_ecs against PCL's VoxelGrid, UniformSampling, RandomSample,
// NormalSpaceSampling and FarthestPointSampling, CGAL's grid, hierarchy and WLOP simplification,
// and the Python samplers (MeshLab and point-cloud-utils Poisson-disk, bucket farthest-point
// sampling; bench/py_peers.py, run with --python), at the same output size (each peer's own
// parameter searched until the size is within 1%), on every shared scan. Every run is timed in a
// child process of its own (peak memory there); the parent measures the quality of what it wrote
// with the pcl_ecs_eval metrics.
//
//   bench_peers --data ../shared/data --out bench/results/peers.json [--ratios 0.1,0.03,0.01]
//               [--inputs bunny,fandisk] [--workdir DIR] [--methods pcl_ecs]  (rerun some, merge into OUT)
//               [--python bench/.venv/bin/python --py-peers bench/py_peers.py]
#include "bench_common.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/eval/quality_metrics.h>
#include <pcl_ecs/feature_aware_cover_simplify.h>
#include <pcl_ecs/io/cloud_io.h>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/grid_simplify_point_set.h>
#include <CGAL/hierarchy_simplify_point_set.h>
#include <CGAL/wlop_simplify_and_regularize_point_set.h>

#include <pcl/common/common.h>
#include <pcl/conversions.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/filters/farthest_point_sampling.h>
#include <pcl/filters/normal_space.h>
#include <pcl/filters/random_sample.h>
#include <pcl/filters/uniform_sampling.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/search/kdtree.h>

#include <nlohmann/json.hpp>

#include <iostream>
#include <map>

using namespace pcl_ecs_bench;
using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using K = CGAL::Exact_predicates_inexact_constructions_kernel;

namespace
{
const std::vector<std::string> kMethods = {"pcl_ecs",         "voxel_grid",     "uniform_sampling", "random_sample",
                                           "normal_space",    "fps",            "cgal_grid",        "cgal_hierarchy",
                                           "cgal_wlop",       "meshlab_poisson", "pcu_poisson",     "fpsample_bucket"};

/// The methods bench/py_peers.py runs (in a Python process).
bool isPython(const std::string& m)
{
  return m == "meshlab_poisson" || m == "pcu_poisson" || m == "fpsample_bucket";
}

std::string label(const std::string& m)
{
  static const std::map<std::string, std::string> names = {
      {"pcl_ecs", "pcl_ecs"},
      {"voxel_grid", "PCL VoxelGrid"},
      {"uniform_sampling", "PCL UniformSampling"},
      {"random_sample", "PCL RandomSample"},
      {"normal_space", "PCL NormalSpaceSampling"},
      {"fps", "PCL FarthestPointSampling"},
      {"cgal_grid", "CGAL grid_simplify"},
      {"cgal_hierarchy", "CGAL hierarchy_simplify"},
      {"cgal_wlop", "CGAL WLOP"},
      {"meshlab_poisson", "MeshLab Poisson-disk"},
      {"pcu_poisson", "point-cloud-utils Poisson-disk"},
      {"fpsample_bucket", "fpsample bucket FPS"}};
  return names.at(m);
}

Cloud::Ptr loadFinite(const std::string& path)
{
  pcl::PCLPointCloud2 blob;
  pcl_ecs::io::readCloud(path, blob);
  Cloud all;
  pcl_ecs::io::fromCloud(blob, all);
  auto c = std::make_shared<Cloud>();
  for (const auto& p : all)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
      c->push_back(p);
  c->width = static_cast<std::uint32_t>(c->size());
  c->height = 1;
  c->is_dense = true;
  return c;
}

std::vector<K::Point_3> toCgal(const Cloud& c)
{
  std::vector<K::Point_3> v;
  v.reserve(c.size());
  for (const auto& p : c)
    v.emplace_back(p.x, p.y, p.z);
  return v;
}

Cloud fromCgal(const std::vector<K::Point_3>& v)
{
  Cloud c;
  for (const auto& p : v)
    c.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
  return c;
}

/// One method at one parameter; `target` is for the methods that take a count.
Cloud runMethod(const std::string& m, const Cloud::Ptr& in, double param, std::size_t target, double cap = 0,
                double gap = -1, double feature_spacing = 0)
{
  Cloud out;
  if (m == "pcl_ecs")
  {
    // With a count, the target-size run itself (the mode a user calls: its search, the relaxed
    // cover it settles on and the top-up to the count); without one, the plain run at the T_err,
    // radius cap, gap bound and feature spacing given (a sweep's point).
    pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ> f;
    if (target > 0)
      f.setTargetSize(target);
    else
    {
      f.setErrorThreshold(param);
      if (cap > 0)
        f.setRadiusCapFactor(cap);
      if (gap >= 0)
        f.setMaxGapFactor(gap);
      f.setFeatureSpacing(feature_spacing);
    }
    f.setInputCloud(in);
    f.filter(out);
  }
  else if (m == "voxel_grid")
  {
    pcl::VoxelGrid<pcl::PointXYZ> f;
    const auto leaf = static_cast<float>(param);
    f.setLeafSize(leaf, leaf, leaf);
    f.setInputCloud(in);
    f.filter(out);
  }
  else if (m == "uniform_sampling")
  {
    pcl::UniformSampling<pcl::PointXYZ> f;
    f.setRadiusSearch(param);
    f.setInputCloud(in);
    f.filter(out);
  }
  else if (m == "random_sample")
  {
    pcl::RandomSample<pcl::PointXYZ> f;
    f.setSample(static_cast<unsigned>(target));
    f.setSeed(42);
    f.setInputCloud(in);
    f.filter(out);
  }
  else if (m == "normal_space")
  {
    pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne;
    ne.setInputCloud(in);
    ne.setSearchMethod(std::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
    ne.setKSearch(16);
    auto normals = std::make_shared<pcl::PointCloud<pcl::Normal>>();
    ne.compute(*normals);
    pcl::NormalSpaceSampling<pcl::PointXYZ, pcl::Normal> f;
    f.setInputCloud(in);
    f.setNormals(normals);
    f.setBins(4, 4, 4);
    f.setSample(static_cast<unsigned>(target));
    f.setSeed(42);
    f.filter(out);
  }
  else if (m == "fps")
  {
    pcl::FarthestPointSampling<pcl::PointXYZ> f;
    f.setSample(static_cast<int>(target));
    f.setSeed(42);
    f.setInputCloud(in);
    f.filter(out);
  }
  else if (m == "cgal_grid")
  {
    auto pts = toCgal(*in);
    pts.erase(CGAL::grid_simplify_point_set(pts, param), pts.end());
    out = fromCgal(pts);
  }
  else if (m == "cgal_hierarchy")
  {
    auto pts = toCgal(*in);
    pts.erase(CGAL::hierarchy_simplify_point_set(pts, CGAL::parameters::size(static_cast<unsigned>(std::lround(param)))),
              pts.end());
    out = fromCgal(pts);
  }
  else if (m == "cgal_wlop")
  {
    auto pts = toCgal(*in);
    std::vector<K::Point_3> res;
    const double pct = 100.0 * static_cast<double>(target) / static_cast<double>(in->size());
    CGAL::wlop_simplify_and_regularize_point_set<CGAL::Sequential_tag>(pts, std::back_inserter(res),
                                                                       CGAL::parameters::select_percentage(pct));
    out = fromCgal(res);
  }
  else
    throw std::runtime_error("unknown method " + m);
  return out;
}

std::vector<std::string> split(const std::string& s)
{
  std::vector<std::string> v;
  std::stringstream ss(s);
  for (std::string x; std::getline(ss, x, ',');)
    if (!x.empty())
      v.push_back(x);
  return v;
}

struct InputSpec
{
  std::string name, file, mesh, half;
};

/// Every shared scan, with its reference mesh where there is one, and the half it belongs to: the
/// defaults are chosen on the tuning half and judged on the checking half (docs/RESULTS.md). Each
/// half mixes CAD, organic and real scans; the tuning half holds the five scans the defaults were
/// first chosen on.
std::vector<InputSpec> sharedInputs(const std::string& data)
{
  auto scan = [&](const std::string& name, const std::string& file, bool mesh, const std::string& half) {
    return InputSpec{name, data + "/" + file, mesh ? data + "/" + name + "_mesh.ply" : "", half};
  };
  return {scan("bunny", "bunny.pcd", true, "tuning"),
          scan("fandisk", "fandisk_scan.pcd", true, "tuning"),
          scan("bun000", "bun000_rangescan.pcd", false, "tuning"),
          scan("mug", "table_scene_mug_organized.pcd", false, "tuning"),
          scan("terrain", "terrain_csite1_utm.pcd", false, "tuning"),
          scan("pinion", "pinion_scan.pcd", true, "tuning"),
          scan("turbine", "turbine_scan.pcd", true, "tuning"),
          scan("spot", "spot_scan.pcd", true, "tuning"),
          scan("fertility", "fertility_scan.pcd", true, "tuning"),
          scan("room", "room_scan2.pcd", false, "tuning"),
          scan("joint", "joint_scan.pcd", true, "checking"),
          scan("spool", "spool_scan.pcd", true, "checking"),
          scan("part", "part_scan.pcd", true, "checking"),
          scan("camelhead", "camelhead_scan.pcd", true, "checking"),
          scan("elephant", "elephant_scan.pcd", true, "checking"),
          scan("terrain2", "terrain_csite2_utm.pcd", false, "checking"),
          scan("kinect", "kinect_capture0001.pcd", false, "checking"),
          scan("face", "face_model.pcd", false, "checking"),
          scan("region_rgb", "region_growing_rgb.pcd", false, "checking"),
          scan("rops", "rops_points.pcd", false, "checking")};
}

/// Run bench/py_peers.py METHOD on the raw float32 copy of the input; parse the line it prints.
Measure runPython(const std::string& python, const std::string& script, const std::string& method,
                  const std::string& raw, std::size_t target, const std::string& out_file)
{
  if (python.empty() || script.empty())
    throw std::runtime_error("no --python and --py-peers given");
  return runMeasured("'" + python + "' '" + script + "' " + method + " '" + raw + "' " + std::to_string(target) +
                     " '" + out_file + "'");
}
}  // namespace

int main(int argc, char** argv)
{
  std::string data = "../shared/data", out_path = "peers.json", workdir = "/tmp/pcl_ecs_peers", input, write;
  std::string child, python, py_peers;
  double param = 0, cap = 0, gap = -1, feature_spacing = 0;
  std::size_t target = 0;
  std::vector<double> ratios = {0.10, 0.03, 0.01};
  std::vector<std::string> only, methods = kMethods;
  bool merge = false;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc)
        throw std::runtime_error(a + " needs a value");
      return argv[++i];
    };
    if (a == "--data")
      data = next();
    else if (a == "--out")
      out_path = next();
    else if (a == "--workdir")
      workdir = next();
    else if (a == "--ratios")
    {
      ratios.clear();
      for (const auto& r : split(next()))
        ratios.push_back(std::stod(r));
    }
    else if (a == "--inputs")
      only = split(next());
    else if (a == "--methods")
    {
      // Rerun only these methods and merge them into the existing OUT (the others' rows are kept).
      methods = split(next());
      merge = true;
    }
    else if (a == "--python")
      python = next();
    else if (a == "--py-peers")
      py_peers = next();
    else if (a == "--input")
      input = next();
    else if (a == "--target")
      target = std::stoull(next());
    else if (a == "--child")
    {
      child = next();
      param = std::stod(next());
    }
    else if (a == "--write")
      write = next();
    else if (a == "--cap")
      cap = std::stod(next());
    else if (a == "--gap")
      gap = std::stod(next());
    else if (a == "--feature-spacing")
      feature_spacing = std::stod(next());
    else
    {
      std::fprintf(stderr, "bench_peers: unknown argument %s\n", a.c_str());
      return 2;
    }
  }

  if (!child.empty())
  {
    Cloud::Ptr in = std::make_shared<Cloud>();
    pcl::io::loadPCDFile(input, *in);
    Cloud out;
    const Measure m = measureHere([&] {
      out = runMethod(child, in, param, target, cap, gap, feature_spacing);
      return out.size();
    });
    if (!write.empty() && !out.empty())
      pcl::io::savePCDFileBinary(write, out);
    std::printf("%zu %.9f %.3f\n", m.size, m.seconds, m.peak_extra_mib);
    return 0;
  }

  std::filesystem::create_directories(workdir);
  const std::vector<InputSpec> inputs = sharedInputs(data);
  nlohmann::json all = nlohmann::json::array();
  nlohmann::json previous = nlohmann::json::array();
  if (merge && std::filesystem::exists(out_path))
    previous = nlohmann::json::parse(std::ifstream(out_path));
  for (const auto& spec : inputs)
  {
    if (!only.empty() && std::find(only.begin(), only.end(), spec.name) == only.end())
      continue;
    const Cloud::Ptr cloud = loadFinite(spec.file);
    const std::string finite_path = workdir + "/" + spec.name + "_input.pcd";
    pcl::io::savePCDFileBinary(finite_path, *cloud);
    const std::string raw_path = workdir + "/" + spec.name + "_input.f32";  // for the Python samplers
    {
      std::ofstream raw(raw_path, std::ios::binary);
      for (const auto& p : *cloud)
        raw.write(reinterpret_cast<const char*>(p.data), 3 * sizeof(float));
    }
    pcl_ecs::eval::TriangleMesh mesh;
    if (!spec.mesh.empty())
    {
      pcl::PolygonMesh pm;
      pcl::io::loadPLYFile(spec.mesh, pm);
      Cloud v;
      pcl_ecs::io::fromCloud(pm.cloud, v);
      for (const auto& p : v)
        mesh.vertices.emplace_back(p.x, p.y, p.z);
      for (const auto& poly : pm.polygons)
        mesh.triangles.emplace_back(poly.vertices[0], poly.vertices[1], poly.vertices[2]);
    }
    Eigen::Vector4f lo, hi;
    pcl::getMinMax3D(*cloud, lo, hi);
    const double L = (hi - lo).head<3>().norm();
    for (const double ratio : ratios)
    {
      const auto n = cloud->size();
      const auto want = static_cast<std::size_t>(std::llround(ratio * static_cast<double>(n)));
      std::printf("\n### %s: %zu points, %.0f%% = %zu\n\n", spec.name.c_str(), n, 100 * ratio, want);
      std::printf("| method | size | time s | peak MiB | surface RMS | tangent RMS | coverage max | mesh mean | edge mean |\n");
      std::printf("| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n");
      nlohmann::json entry = {{"input", spec.name}, {"half", spec.half}, {"has_mesh", !spec.mesh.empty()},
                              {"points", n}, {"ratio", ratio}, {"target", want}, {"methods", nlohmann::json::array()}};
      for (const auto& m : kMethods)
      {
        if (std::find(methods.begin(), methods.end(), m) == methods.end())
        {
          // Not rerun: the previous row, if any.
          for (const auto& e : previous)
            if (e["input"] == spec.name && std::abs(e["ratio"].get<double>() - ratio) < 1e-12)
              for (const auto& row : e["methods"])
                if (row["method"] == m)
                  entry["methods"].push_back(row);
          continue;
        }
        // The parameter for the size (untimed, in this process).
        double p = 0, cap_used = 0, gap_used = -1, spacing_used = 0;
        if (m == "pcl_ecs")
        {
          pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ> f;
          f.setTargetSize(want);
          f.setInputCloud(cloud);
          Cloud tmp;
          f.filter(tmp);
          p = f.getResult().summary.error_threshold;
          const auto& s = f.getResult().summary;
          cap_used = s.radius_cap_factor;
          spacing_used = s.feature_spacing;
          // The gap bound as a factor of that cap (the search may have widened it).
          gap_used = s.max_gap > 0 ? s.max_gap / (s.radius_cap_factor * s.neighborhood_radius) : 0.0;
        }
        else if (m == "voxel_grid" || m == "uniform_sampling" || m == "cgal_grid")
          p = searchParameter(L * 1e-5, L * 0.5, want, [&](double x) { return runMethod(m, cloud, x, want).size(); });
        else if (m == "cgal_hierarchy")
          p = std::round(searchParameter(1.0, 2000.0, want, [&](double x) { return runMethod(m, cloud, std::round(x), want).size(); }, 24));
        const std::string out_file = workdir + "/" + spec.name + "_" + m + ".pcd";
        std::filesystem::remove(out_file);
        std::ostringstream extra;
        extra.precision(17);
        extra << " --write '" << out_file << "'";
        if (cap_used > 0)
          extra << " --cap " << cap_used;
        if (gap_used >= 0)
          extra << " --gap " << gap_used;
        if (spacing_used > 0)
          extra << " --feature-spacing " << spacing_used;
        Measure meas;
        nlohmann::json j = {{"method", m}, {"label", label(m)}, {"parameter", p}};
        if (cap_used > 0)
          j["radius_cap_factor"] = cap_used;
        if (gap_used >= 0)
          j["max_gap_factor"] = gap_used;
        if (spacing_used > 0)
          j["feature_spacing"] = spacing_used;
        try
        {
          meas = isPython(m) ? runPython(python, py_peers, m, raw_path, want, out_file)
                             : runChild({"--input", finite_path, "--target", std::to_string(want)}, m, p, extra.str());
        }
        catch (const std::exception& e)
        {
          j["error"] = e.what();
          entry["methods"].push_back(j);
          std::printf("| %s | failed | | | | | | | |\n", label(m).c_str());
          continue;
        }
        Cloud simplified;
        pcl::io::loadPCDFile(out_file, simplified);
        pcl_ecs::eval::QualityMetrics q;
        pcl_ecs::eval::evaluateQuality(*cloud, simplified, mesh.triangles.empty() ? nullptr : &mesh, q);
        j.update({{"size", meas.size},
                  {"seconds", meas.seconds},
                  {"peak_extra_mib", meas.peak_extra_mib},
                  {"surface_rms", q.surface_rms},
                  {"surface_p99", q.surface_p99},
                  {"coverage_mean", q.coverage_mean},
                  {"coverage_max", q.coverage_max},
                  {"tangent_rms", q.tangent_rms},
                  {"tangent_p99", q.tangent_p99},
                  {"hausdorff", q.hausdorff},
                  {"has_mesh", q.has_mesh},
                  {"mesh_mean", q.mesh_mean},
                  {"mesh_p99", q.mesh_p99},
                  {"mesh_max", q.mesh_max},
                  {"edge_mean", q.edge_mean},
                  {"edge_p90", q.edge_p90}});
        entry["methods"].push_back(j);
        if (q.has_mesh)
          std::printf("| %s | %zu | %.3f | %.1f | %.2e | %.2e | %.2e | %.2e | %.2e |\n", label(m).c_str(), meas.size,
                      meas.seconds, meas.peak_extra_mib, q.surface_rms, q.tangent_rms, q.coverage_max, q.mesh_mean,
                      q.edge_mean);
        else
          std::printf("| %s | %zu | %.3f | %.1f | %.2e | %.2e | %.2e | | |\n", label(m).c_str(), meas.size, meas.seconds,
                      meas.peak_extra_mib, q.surface_rms, q.tangent_rms, q.coverage_max);
        std::fflush(stdout);
      }
      all.push_back(entry);
      std::ofstream(out_path) << all.dump(2) << "\n";  // after every block: a long run keeps what it did
    }
  }
  return 0;
}
