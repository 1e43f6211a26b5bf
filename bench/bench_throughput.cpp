// bench_throughput — the issue-2 benchmark: time per stage, points per second end to end and peak
// memory of pcl_ecs on a dense mesh sample or a scan, against PCL's VoxelGrid and (when built with
// CGAL) CGAL's hierarchy_simplify_point_set at the same output size, in the same run.
//
//   bench_throughput --mesh ../shared/data/bunny_mesh.ply --points 1000000 [--keep 0.10]
//   bench_throughput --cloud ../shared/data/terrain_csite1_utm.pcd [--keep 0.10] [--repeat 3] [--json out.json]
//   bench_throughput --mesh ../shared/data/bunny_mesh.ply --points 1000000 --save-input m.pcd  (the sample only)
//   bench_throughput --cloud C.pcd --size N --peers-only --json out.json  (the peers at N points; bench/modes.py)
#include "bench_common.h"
#include "mesh_sampler.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/feature_aware_cover_simplify.h>
#include <pcl_ecs/io/cloud_io.h>

#include <chrono>
#include <stdexcept>
#include <filesystem>
#include <sstream>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <string>

#include <nlohmann/json.hpp>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/filters/voxel_grid.h>

#ifdef PCL_ECS_BENCH_WITH_CGAL
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/hierarchy_simplify_point_set.h>
#endif

namespace
{
using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using namespace pcl_ecs_bench;
}  // namespace

int main(int argc, char** argv)
{
  std::string mesh, cloud_path, json_path, save_path;
  std::size_t points = 1000000;
  double keep = 0.10;
  int threads = 0;
  int repeat = 3;  // timed runs per method: the least time is reported
  std::size_t size = 0;     // the output size to calibrate every method to (0: keep × input)
  bool peers_only = false;  // time the peers only (pcl_ecs is timed as a whole process elsewhere)
  std::string child_method;
  double child_param = 0.0;
  std::vector<std::string> input_args;  // what a child needs to rebuild the same input
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    auto next = [&]() { return std::string(i + 1 < argc ? argv[++i] : ""); };
    auto keep_arg = [&](const std::string& v) {
      input_args.push_back(a);
      input_args.push_back(v);
      return v;
    };
    if (a == "--mesh") mesh = keep_arg(next());
    else if (a == "--cloud") cloud_path = keep_arg(next());
    else if (a == "--points") points = std::stoull(keep_arg(next()));
    else if (a == "--keep") keep = std::stod(next());
    else if (a == "--threads") threads = std::stoi(keep_arg(next()));
    else if (a == "--json") json_path = next();
    else if (a == "--repeat") repeat = std::max(1, std::stoi(next()));
    else if (a == "--save-input") save_path = next();
    else if (a == "--size") size = std::stoull(next());
    else if (a == "--peers-only") peers_only = true;
    else if (a == "--child")
    {
      child_method = next();
      child_param = std::stod(next());
    }
    else
    {
      std::cerr << "usage: bench_throughput (--mesh M.ply [--points N] | --cloud C.pcd) [--keep R | --size N] "
                   "[--peers-only] [--threads T] [--repeat N] [--json F] [--save-input F.pcd]\n";
      return 2;
    }
  }
  Cloud::Ptr cloud;
  std::string source;
  if (!mesh.empty())
  {
    cloud = pcl_ecs_bench::sampleTriangles(pcl_ecs_bench::loadTriangles(mesh), points, 0.0, 1);
    source = mesh + " sampled to " + std::to_string(points) + " points";
  }
  else
  {
    pcl::PCLPointCloud2 blob;
    pcl_ecs::io::readCloud(cloud_path, blob);
    cloud = std::make_shared<Cloud>();
    pcl_ecs::io::fromCloud(blob, *cloud);
    source = cloud_path;
  }
  const std::size_t n = cloud->size();
  if (!save_path.empty())  // the exact input, for profiling the same cloud with other tools
    return pcl::io::savePCDFileBinary(save_path, *cloud) < 0 ? 1 : 0;

  // The three methods, each run with its own parameter (T_err, leaf size, cluster size).
  Cloud out;
  pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ> ecs;
  ecs.setNumberOfThreads(threads);
  // The child runs at the calibrated T_err with the plain radius cap, so the calibration uses it too
  // (the throughput figures of docs/BENCHMARKS.md were measured that way).
  ecs.setTargetRadiusCap(0.0);
  ecs.setInputCloud(cloud);
  auto run_ecs = [&](double terr) {
    ecs.setTargetSize(0);
    ecs.setErrorThreshold(terr);
    ecs.filter(out);
    return out.size();
  };
  pcl::VoxelGrid<pcl::PointXYZ> vg;
  vg.setInputCloud(cloud);
  auto run_vg = [&](double leaf) {
    vg.setLeafSize(static_cast<float>(leaf), static_cast<float>(leaf), static_cast<float>(leaf));
    vg.filter(out);
    return out.size();
  };
#ifdef PCL_ECS_BENCH_WITH_CGAL
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  std::vector<K::Point_3> base;
  base.reserve(n);
  for (const auto& p : *cloud)
    base.emplace_back(p.x, p.y, p.z);
  std::vector<K::Point_3> work;
  auto run_hierarchy = [&](double size) {
    work = base;
    work.erase(CGAL::hierarchy_simplify_point_set(
                   work, CGAL::parameters::size(static_cast<unsigned>(std::lround(size)))),
               work.end());
    return work.size();
  };
#endif

  if (!child_method.empty())
  {
    std::function<std::size_t()> run;
    if (child_method == "pcl_ecs")
      run = [&] { return run_ecs(child_param); };
    else if (child_method == "voxel_grid")
      run = [&] { return run_vg(child_param); };
#ifdef PCL_ECS_BENCH_WITH_CGAL
    else if (child_method == "cgal_hierarchy")
      run = [&] { return run_hierarchy(child_param); };
#endif
    else
      return 2;
    const Measure m = measureHere(run);
    std::printf("%zu %.9f %.3f\n", m.size, m.seconds, m.peak_extra_mib);
    return 0;
  }

  const std::size_t target = size > 0 ? size : static_cast<std::size_t>(std::llround(keep * n));
  std::printf("input: %s (%zu points), target %zu (%.0f%%), threads %d\n", source.c_str(), n,
              target, 100 * keep, pcl_ecs::resolveThreads(threads));

  nlohmann::json j;
  j["input"] = source;
  j["points"] = n;
  j["target"] = target;
  j["threads"] = pcl_ecs::resolveThreads(threads);
  j["repeat"] = repeat;
  const double L_box = [&] {
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e30f), hi = -lo;
    for (const auto& p : *cloud)
      if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
      {
        lo = lo.cwiseMin(p.getVector3fMap());
        hi = hi.cwiseMax(p.getVector3fMap());
      }
    return static_cast<double>((hi - lo).norm());
  }();
  // The peers at the target size: each one's parameter calibrated (untimed), then the best of
  // `repeat` runs, each in a process of its own. Into `j`; returned for the printout.
  struct PeerTimes
  {
    Measure vg, h;
  };
  auto time_peers = [&] {
    PeerTimes p;
    const double leaf = searchParameter(L_box * 1e-5, L_box * 0.5, target, run_vg);
    p.vg = bestOfChildren(repeat, input_args, "voxel_grid", leaf);
    j["voxel_grid"] = {{"leaf", leaf}, {"size", p.vg.size}, {"seconds", p.vg.seconds},
                       {"peak_extra_mib", p.vg.peak_extra_mib}};
#ifdef PCL_ECS_BENCH_WITH_CGAL
    const double csize = std::round(searchParameter(1.0, 1000.0, target, run_hierarchy, 20));
    work.clear();
    work.shrink_to_fit();
    p.h = bestOfChildren(repeat, input_args, "cgal_hierarchy", csize);
    j["cgal_hierarchy"] = {{"size_param", csize}, {"size", p.h.size}, {"seconds", p.h.seconds},
                           {"peak_extra_mib", p.h.peak_extra_mib}};
#endif
    return p;
  };
  if (peers_only)
  {
    time_peers();
    std::printf("%s\n", j.dump(2).c_str());
    if (!json_path.empty())
      std::ofstream(json_path) << j.dump(2) << "\n";
    return 0;
  }

  // Calibrate each method's parameter for the target size (untimed), then time one run of each
  // in a process of its own.
  ecs.setTargetSize(target);
  ecs.filter(out);
  const double terr = ecs.getResult().summary.error_threshold;
  const Measure m_ecs = bestOfChildren(repeat, input_args, "pcl_ecs", terr);
  // Stage timings of the same run, in this process: each stage's least time over the repeats.
  run_ecs(terr);
  const pcl_ecs::Summary s = ecs.getResult().summary;
  pcl_ecs::StageTimings t = s.timings;
  for (int r = 1; r < repeat; ++r)
  {
    run_ecs(terr);
    keepLeastStageTimes(t, ecs.getResult().summary.timings);
  }
  const PeerTimes peers = time_peers();
  const Measure& m_vg = peers.vg;

  j["pcl_ecs"] = {{"terr", terr},          {"size", m_ecs.size},
                  {"seconds", m_ecs.seconds}, {"points_per_second", n / m_ecs.seconds},
                  {"peak_extra_mib", m_ecs.peak_extra_mib},
                  {"features", s.feature_points},
                  {"stages_s", {{"preparation", t.preparation}, {"neighbors", t.neighbors}, {"normals", t.normals},
                                {"weights", t.weights}, {"features", t.features}, {"density", t.density},
                                {"curvature", t.curvature}, {"cover", t.cover}, {"output", t.output}}}};
  std::printf("%-28s %9s %9s %12s %10s\n", "method", "size", "time s", "points/s", "peak MiB");
  std::printf("%-28s %9zu %9.3f %12.0f %10.1f\n", "pcl_ecs", m_ecs.size, m_ecs.seconds, n / m_ecs.seconds, m_ecs.peak_extra_mib);
  std::printf("  stages (s): neighbours %.3f normals %.3f weights %.3f features %.3f density %.3f curvature %.3f cover %.3f output %.3f\n",
              t.neighbors, t.normals, t.weights, t.features, t.density, t.curvature, t.cover, t.output);
  std::printf("%-28s %9zu %9.3f %12.0f %10.1f  (pcl_ecs time / this: %.1fx)\n", "pcl::VoxelGrid", m_vg.size,
              m_vg.seconds, n / m_vg.seconds, m_vg.peak_extra_mib, m_ecs.seconds / m_vg.seconds);

#ifdef PCL_ECS_BENCH_WITH_CGAL
  const Measure& m_h = peers.h;
  std::printf("%-28s %9zu %9.3f %12.0f %10.1f  (pcl_ecs time / this: %.1fx)\n", "CGAL hierarchy_simplify", m_h.size,
              m_h.seconds, n / m_h.seconds, m_h.peak_extra_mib, m_ecs.seconds / m_h.seconds);
#endif
  if (!json_path.empty())
    std::ofstream(json_path) << j.dump(2) << "\n";
  return 0;
}
