// bench_common.h — what the benchmark programs share: each method timed in a child process of its
// own (peak memory measured there), and the bisection of a method's parameter for a target size.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <pcl_ecs/result.h>

namespace pcl_ecs_bench
{
using Clock = std::chrono::steady_clock;

/// A field of /proc/self/status, in MiB.
inline double statusMiB(const char* key)
{
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(key, 0) == 0)
      return std::stod(line.substr(std::strlen(key))) / 1024.0;
  return -1.0;
}

/// Keep in `least` each stage's least time of `least` and `run` (over repeated runs, the steadiest
/// figure on a busy machine: load adds time, never removes it).
inline void keepLeastStageTimes(pcl_ecs::StageTimings& least, const pcl_ecs::StageTimings& run)
{
  for (auto [mine, theirs] : {std::pair{&least.preparation, run.preparation}, {&least.neighbors, run.neighbors},
                              {&least.normals, run.normals}, {&least.weights, run.weights},
                              {&least.features, run.features}, {&least.density, run.density},
                              {&least.curvature, run.curvature}, {&least.cover, run.cover},
                              {&least.output, run.output}, {&least.total, run.total}})
    *mine = std::min(*mine, theirs);
}

struct Measure
{
  double seconds = 0, peak_extra_mib = 0;
  std::size_t size = 0;
};

/// In a fresh child process (see runChild): reset the peak-RSS mark, run, and report the time and
/// the peak resident memory above what the loaded input already used.
inline Measure measureHere(const std::function<std::size_t()>& run)
{
  std::ofstream("/proc/self/clear_refs") << "5";  // VmHWM := VmRSS (Linux >= 4.0)
  const double base = statusMiB("VmRSS:");
  const auto t0 = Clock::now();
  Measure m;
  m.size = run();
  m.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  m.peak_extra_mib = statusMiB("VmHWM:") - base;
  return m;
}

/// Run `cmd` (through a shell) and parse the line "SIZE SECONDS PEAK_EXTRA_MIB" it prints.
inline Measure runMeasured(const std::string& cmd)
{
  FILE* pipe = ::popen(cmd.c_str(), "r");
  if (!pipe)
    throw std::runtime_error("cannot start " + cmd);
  Measure m;
  const int got = std::fscanf(pipe, "%zu %lf %lf", &m.size, &m.seconds, &m.peak_extra_mib);
  const int status = ::pclose(pipe);
  if (got != 3 || status != 0)
    throw std::runtime_error("the child run failed: " + cmd);
  return m;
}

/// Run this program again as `--child METHOD PARAM` with the same input flags, so that each
/// method's memory is measured in a process of its own; parse the line it prints.
inline Measure runChild(const std::vector<std::string>& input_args, const std::string& method, double param,
                 const std::string& extra = "")
{
  std::ostringstream cmd;
  cmd << std::filesystem::read_symlink("/proc/self/exe").string();  // popen runs a shell
  for (const auto& a : input_args)
    cmd << " '" << a << "'";
  cmd.precision(17);
  cmd << " --child " << method << " " << param << extra;
  return runMeasured(cmd.str());
}

/// The best of `repeat` runs in fresh processes (the least time; the largest peak memory): this
/// machine's speed moves by 10-15% from minute to minute, the least time is the repeatable one.
inline Measure bestOfChildren(int repeat, const std::vector<std::string>& input_args, const std::string& method,
                              double param, const std::string& extra = "")
{
  Measure best = runChild(input_args, method, param, extra);
  for (int r = 1; r < repeat; ++r)
  {
    const Measure m = runChild(input_args, method, param, extra);
    best.seconds = std::min(best.seconds, m.seconds);
    best.peak_extra_mib = std::max(best.peak_extra_mib, m.peak_extra_mib);
  }
  return best;
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
}  // namespace pcl_ecs_bench
