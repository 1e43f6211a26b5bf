// node_options.h — ecs_node's settings: the launch file (YAML) and the flags, checked (one
// UsageError naming what is wrong). Its streaming loop is in ecs_node.cpp.
#pragma once

#include "node_io.h"

#include <pcl_ecs/parameters.h>

#include <cstdint>
#include <string>

namespace pcl_ecs
{
namespace node
{

/** \brief ecs_node's --help text (the filter's flags follow it). */
extern const char* const kUsage;

struct Options
{
  std::string source = "stdin", sink = "stdout";
  std::size_t queue = 8;
  bool drop_oldest = false;
  int workers = 2;
  double stats_interval = 5.0;
  int poll_ms = 100;
  bool once = false, quiet = false;
  std::uint64_t max_frame_bytes = node::kDefaultMaxFrameBytes;
  std::uint64_t max_bytes_in_flight = 1ull << 30;
  double read_timeout = node::kDefaultReadTimeoutMs / 1000.0;
  Parameters params;
};

/** \brief Apply the launch file at `path` to `o` (flags given after --launch override it).
 * Throws tools::UsageError naming the file and the key. */
void applyYaml(const std::string& path, Options& o);

/** \brief The settings from the command line (and the launch files it names); `done` when it
 * printed --help or --version. Throws tools::UsageError. */
Options parseArgs(int argc, char** argv, bool& done);

}  // namespace node
}  // namespace pcl_ecs
