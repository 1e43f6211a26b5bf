// quick_run: load a PCD, run the filter with T_err / α / cap from argv, print the summary.
#include "bench_common.h"

#include <pcl_ecs/feature_aware_cover_simplify.h>

#include <cstdio>
#include <cstdlib>
#include <algorithm>
#include <string>

#include <pcl/io/pcd_io.h>

int main(int argc, char** argv)
{
  if (argc < 2)
  {
    std::fprintf(stderr, "usage: quick_run FILE.pcd [terr] [alpha] [cap] [target] [threads] [form] [repeat]\n");
    return 2;
  }
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  if (pcl::io::loadPCDFile(argv[1], *cloud) < 0)
    return 1;
  pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ> f;
  f.setInputCloud(cloud);
  if (argc > 2) f.setErrorThreshold(std::atof(argv[2]));
  if (argc > 3) f.setFeatureFactor(std::atof(argv[3]));
  if (argc > 4) f.setRadiusCapFactor(std::atof(argv[4]));
  if (argc > 5) f.setTargetSize(std::strtoull(argv[5], nullptr, 10));
  if (argc > 6) f.setNumberOfThreads(std::atoi(argv[6]));
  if (argc > 7 && std::string(argv[7]) == "paper") f.setErrorForm(pcl_ecs::ErrorForm::Paper);
  pcl::PointCloud<pcl::PointXYZ> out;
  f.filter(out);
  const auto& s = f.getResult().summary;
  // With a repeat count, each stage's least time over that many runs (to compare two builds by).
  pcl_ecs::StageTimings t = s.timings;
  const int repeat = argc > 8 ? std::max(1, std::atoi(argv[8])) : 1;
  for (int r = 1; r < repeat; ++r)
  {
    f.filter(out);
    pcl_ecs_bench::keepLeastStageTimes(t, f.getResult().summary.timings);
  }
  std::printf("in %zu out %zu (%.2f%%) features %zu balls %zu fallbacks %zu T %.3g maxE %.3g "
              "spacing %.4g L %.4g iters %d evals/ball %.2f\n",
              s.finite_points, out.size(), 100.0 * out.size() / s.finite_points, s.feature_points,
              s.balls, s.centre_fallbacks, s.error_threshold, s.max_error, s.mean_spacing,
              s.bbox_diagonal, s.target_iterations, double(s.radius_evaluations) / double(std::max<std::size_t>(1, s.balls)));
  std::printf("time: prep %.3f nn %.3f normals %.3f w %.3f feat %.3f dens %.3f curv %.3f cover %.3f "
              "out %.3f total %.3f  => %.0f pts/s\n",
              t.preparation, t.neighbors, t.normals, t.weights, t.features, t.density, t.curvature,
              t.cover, t.output, t.total, s.finite_points / t.total);
  return 0;
}
