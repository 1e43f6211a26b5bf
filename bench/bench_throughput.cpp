// bench_throughput — the issue-2 benchmark: time per stage, points per second end to end and peak
// memory of pcl_ecs on a dense mesh sample or a scan, against PCL's VoxelGrid and (when built with
// CGAL) CGAL's hierarchy_simplify_point_set at the same output size, in the same run.
//
//   bench_throughput --mesh ../shared/data/bunny_mesh.ply --points 1000000 [--keep 0.10]
//   bench_throughput --cloud ../shared/data/terrain_csite1_utm.pcd [--keep 0.10] [--json out.json]
#include "mesh_sampler.h"

#include <pcl_ecs/feature_aware_cover_simplify.h>
#include <pcl_ecs/io/cloud_io.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <functional>
#include <iostream>
#include <string>

#include <nlohmann/json.hpp>
#include <pcl/conversions.h>
#include <pcl/filters/voxel_grid.h>

#ifdef PCL_ECS_BENCH_WITH_CGAL
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/hierarchy_simplify_point_set.h>
#endif

namespace
{
using Clock = std::chrono::steady_clock;
using Cloud = pcl::PointCloud<pcl::PointXYZ>;

/// Resident and peak resident memory (MiB) from /proc/self/status.
double procStatusMiB(const char* key)
{
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(key, 0) == 0)
      return std::stod(line.substr(std::strlen(key))) / 1024.0;
  return -1.0;
}

/// Reset the kernel's peak-RSS mark to the current RSS (Linux >= 4.0).
void resetPeak()
{
  std::ofstream("/proc/self/clear_refs") << "5";
}

struct Measure
{
  double seconds = 0, peak_extra_mib = 0;
  std::size_t size = 0;
};

Measure measure(const std::function<std::size_t()>& run)
{
  resetPeak();
  const double base = procStatusMiB("VmRSS:");
  const auto t0 = Clock::now();
  Measure m;
  m.size = run();
  m.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  m.peak_extra_mib = procStatusMiB("VmHWM:") - base;
  return m;
}

/// Geometric bisection of a monotone-decreasing size(param) for the target (within 1%).
template <typename F>
double searchParameter(double lo, double hi, std::size_t target, F size_of, int iterations = 40)
{
  double best = lo, best_err = 1e300;
  for (int i = 0; i < iterations; ++i)
  {
    const double mid = std::sqrt(lo * hi);
    const std::size_t s = size_of(mid);
    const double err = std::abs(static_cast<double>(s) - static_cast<double>(target));
    if (err < best_err)
    {
      best_err = err;
      best = mid;
    }
    if (err <= 0.01 * target)
      break;
    if (s > target)
      lo = mid;
    else
      hi = mid;
  }
  return best;
}
}  // namespace

int main(int argc, char** argv)
{
  std::string mesh, cloud_path, json_path;
  std::size_t points = 1000000;
  double keep = 0.10;
  int threads = 0;
  for (int i = 1; i < argc; ++i)
  {
    const std::string a = argv[i];
    auto next = [&]() { return std::string(i + 1 < argc ? argv[++i] : ""); };
    if (a == "--mesh") mesh = next();
    else if (a == "--cloud") cloud_path = next();
    else if (a == "--points") points = std::stoull(next());
    else if (a == "--keep") keep = std::stod(next());
    else if (a == "--threads") threads = std::stoi(next());
    else if (a == "--json") json_path = next();
    else
    {
      std::cerr << "usage: bench_throughput (--mesh M.ply [--points N] | --cloud C.pcd) [--keep R] [--threads T] [--json F]\n";
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
    pcl::fromPCLPointCloud2(blob, *cloud);
    source = cloud_path;
  }
  const std::size_t n = cloud->size();
  const std::size_t target = static_cast<std::size_t>(std::llround(keep * n));
  std::printf("input: %s (%zu points), target %zu (%.0f%%), threads %d\n", source.c_str(), n,
              target, 100 * keep, pcl_ecs::resolveThreads(threads));

  // pcl_ecs: calibrate T_err for the target (untimed), then time one run at that T_err.
  pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ> ecs;
  ecs.setNumberOfThreads(threads);
  ecs.setInputCloud(cloud);
  ecs.setTargetSize(target);
  Cloud out;
  ecs.filter(out);
  const double terr = ecs.getResult().summary.error_threshold;
  ecs.setTargetSize(0);
  ecs.setErrorThreshold(terr);
  const Measure m_ecs = measure([&] {
    ecs.filter(out);
    return out.size();
  });
  const pcl_ecs::Summary s = ecs.getResult().summary;
  const pcl_ecs::StageTimings& t = s.timings;

  // PCL VoxelGrid at the same size.
  pcl::VoxelGrid<pcl::PointXYZ> vg;
  vg.setInputCloud(cloud);
  const double L = s.bbox_diagonal;
  const double leaf = searchParameter(L * 1e-5, L * 0.5, target, [&](double l) {
    vg.setLeafSize(static_cast<float>(l), static_cast<float>(l), static_cast<float>(l));
    vg.filter(out);
    return out.size();
  });
  vg.setLeafSize(static_cast<float>(leaf), static_cast<float>(leaf), static_cast<float>(leaf));
  const Measure m_vg = measure([&] {
    vg.filter(out);
    return out.size();
  });

  nlohmann::json j;
  j["input"] = source;
  j["points"] = n;
  j["threads"] = pcl_ecs::resolveThreads(threads);
  j["pcl_ecs"] = {{"terr", terr},          {"size", m_ecs.size},
                  {"seconds", m_ecs.seconds}, {"points_per_second", n / m_ecs.seconds},
                  {"peak_extra_mib", m_ecs.peak_extra_mib},
                  {"features", s.feature_points},
                  {"stages_s", {{"preparation", t.preparation}, {"neighbors", t.neighbors}, {"normals", t.normals},
                                {"weights", t.weights}, {"features", t.features}, {"density", t.density},
                                {"curvature", t.curvature}, {"cover", t.cover}, {"output", t.output}}}};
  j["voxel_grid"] = {{"leaf", leaf}, {"size", m_vg.size}, {"seconds", m_vg.seconds},
                     {"peak_extra_mib", m_vg.peak_extra_mib}};
  std::printf("%-28s %9s %9s %12s %10s\n", "method", "size", "time s", "points/s", "peak MiB");
  std::printf("%-28s %9zu %9.3f %12.0f %10.1f\n", "pcl_ecs", m_ecs.size, m_ecs.seconds, n / m_ecs.seconds, m_ecs.peak_extra_mib);
  std::printf("  stages: nn %.3f normals %.3f weights %.3f features %.3f density %.3f curvature %.3f cover %.3f output %.3f\n",
              t.neighbors, t.normals, t.weights, t.features, t.density, t.curvature, t.cover, t.output);
  std::printf("%-28s %9zu %9.3f %12.0f %10.1f  (pcl_ecs time / this: %.1fx)\n", "pcl::VoxelGrid", m_vg.size,
              m_vg.seconds, n / m_vg.seconds, m_vg.peak_extra_mib, m_ecs.seconds / m_vg.seconds);

#ifdef PCL_ECS_BENCH_WITH_CGAL
  using K = CGAL::Exact_predicates_inexact_constructions_kernel;
  std::vector<K::Point_3> base;
  base.reserve(n);
  for (const auto& p : *cloud)
    base.emplace_back(p.x, p.y, p.z);
  std::vector<K::Point_3> work;
  auto hierarchy = [&](double size) {
    work = base;
    work.erase(CGAL::hierarchy_simplify_point_set(work, CGAL::parameters::size(static_cast<unsigned>(std::lround(size)))),
               work.end());
    return work.size();
  };
  const double csize = std::round(searchParameter(1.0, 1000.0, target, hierarchy, 20));
  work.clear();
  work.shrink_to_fit();
  const Measure m_h = measure([&] { return hierarchy(csize); });
  j["cgal_hierarchy"] = {{"size_param", csize}, {"size", m_h.size}, {"seconds", m_h.seconds},
                         {"peak_extra_mib", m_h.peak_extra_mib}};
  std::printf("%-28s %9zu %9.3f %12.0f %10.1f  (pcl_ecs time / this: %.1fx)\n", "CGAL hierarchy_simplify", m_h.size,
              m_h.seconds, n / m_h.seconds, m_h.peak_extra_mib, m_ecs.seconds / m_h.seconds);
#endif
  if (!json_path.empty())
    std::ofstream(json_path) << j.dump(2) << "\n";
  return 0;
}
