// node_options.cpp — ecs_node's launch file and flags (node_options.h).
#include "node_options.h"

#include "../common/cli.h"

#include <pcl_ecs/stream/out_of_core.h>
#include <pcl_ecs/version.h>

#include <iostream>
#include <set>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

namespace pcl_ecs
{
namespace node
{

const char* const kUsage = R"(Usage: ecs_node [--launch FILE.yaml] [options]

A long-running node: takes point cloud frames from a source, simplifies each with the filter, and
hands them to a sink in the order they came. No ROS needed. SIGINT/SIGTERM stop the source, finish
the frames in flight, flush the sink, print a summary and exit 0.

  --launch FILE.yaml       read the options below from a launch file (flags given after it win)
  --source S               dir:PATH | tcp:PORT | stdin            (default stdin)
  --sink S                 dir:PATH | tcp:HOST:PORT | tcp-listen:PORT | stdout   (default stdout)
  --queue N                frames waiting for a worker, >= 1 (default 8)
  --policy P               when the queue is full: block (default) or drop-oldest
  --workers N              worker threads, >= 1 (default 2)
  --stats-interval S       seconds between stats lines on stderr, 0 = none (default 5)
  --poll-ms MS             directory source: how often to look for new files (default 100)
  --once                   directory source: process the files present, then exit
  --max-frame-bytes SIZE   largest frame, and largest cloud a frame may decode to (points x
                           record size), e.g. 64M (default 256M); larger ones are bad frames
  --max-bytes-in-flight SIZE
                           bytes all input frames hold together while read, queued or processed
                           (default 1G, >= --max-frame-bytes); a reader that would exceed it waits
                           and does not read its peer until frames are done
  --read-timeout S         TCP source: a producer that sends nothing for S seconds in the middle
                           of a frame is dropped, the frame counted as dropped (default 30; 0 =
                           wait for ever). Between frames a producer may be silent for any time
  --quiet                  no stats lines, only errors and the summary

Frames on TCP and pipes: an 8-byte little-endian length, then that many bytes holding a complete
PCD file (any DATA encoding); output frames use the same framing with binary PCD (docs/NODE_PROTOCOL.md).
A directory source reads *.pcd, *.las and *.laz files in name order once each, when their size has
been stable for one poll (writers should write to a temporary name and rename); a directory sink
writes each output to a temporary name and renames it, so a consumer never sees half a frame. A
LAS / LAZ frame goes to a directory sink as LAS / LAZ under its own name, with its header and every
dimension (docs/LAS.md); to any other sink as binary PCD with every dimension as a field.

)";

void applyYaml(const std::string& path, Options& o)
{
  YAML::Node y;
  try
  {
    y = YAML::LoadFile(path);
  }
  catch (const std::exception& e)
  {
    throw tools::UsageError(path + ": " + e.what());
  }
  static const std::set<std::string> known = {"source", "sink", "queue", "policy", "workers",
                                              "stats_interval", "poll_ms", "once", "quiet", "filter",
                                              "max_frame_bytes", "max_bytes_in_flight", "read_timeout"};
  for (const auto& kv : y)
    if (!known.count(kv.first.as<std::string>()))
      throw tools::UsageError(path + ": unknown key '" + kv.first.as<std::string>() + "'");
  try
  {
    if (y["source"]) o.source = y["source"].as<std::string>();
    if (y["sink"]) o.sink = y["sink"].as<std::string>();
    if (y["queue"]) o.queue = y["queue"].as<std::size_t>();
    if (y["max_frame_bytes"] && !stream::parseByteSize(y["max_frame_bytes"].as<std::string>(), o.max_frame_bytes))
      throw tools::UsageError(path + ": max_frame_bytes must be a size like 64M");
    if (y["max_bytes_in_flight"] &&
        !stream::parseByteSize(y["max_bytes_in_flight"].as<std::string>(), o.max_bytes_in_flight))
      throw tools::UsageError(path + ": max_bytes_in_flight must be a size like 1G");
    if (y["read_timeout"]) o.read_timeout = y["read_timeout"].as<double>();
    if (y["policy"])
    {
      const std::string p = y["policy"].as<std::string>();
      if (p != "block" && p != "drop-oldest")
        throw tools::UsageError(path + ": policy must be block or drop-oldest");
      o.drop_oldest = p == "drop-oldest";
    }
    if (y["workers"]) o.workers = y["workers"].as<int>();
    if (y["stats_interval"]) o.stats_interval = y["stats_interval"].as<double>();
    if (y["poll_ms"]) o.poll_ms = y["poll_ms"].as<int>();
    if (y["once"]) o.once = y["once"].as<bool>();
    if (y["quiet"]) o.quiet = y["quiet"].as<bool>();
    if (y["filter"])
      for (const auto& kv : y["filter"])
      {
        // Filter keys are the pcd_simplify flags without the dashes: terr, alpha, k, ...
        const std::string flag = "--" + kv.first.as<std::string>();
        const std::string value = kv.second.IsScalar() ? kv.second.as<std::string>() : std::string();
        const bool is_switch = flag == "--no-adapt" || flag == "--use-input-normals";
        if (is_switch && value != "true")
          continue;
        if (!tools::applyFilterFlag(flag, [&] { return value; }, o.params))
          throw tools::UsageError(path + ": unknown filter key '" + kv.first.as<std::string>() + "'");
      }
  }
  catch (const YAML::Exception& e)
  {
    throw tools::UsageError(path + ": " + e.what());
  }
}

Options parseArgs(int argc, char** argv, bool& done)
{
  Options o;
  o.params.threads = 1;  // the workers are the parallelism of the node
  done = false;
  tools::ArgWalker args(argc, argv);
  while (args.next())
  {
    const std::string a = args.flag();
    auto value = [&]() -> std::string { return args.value(); };
    if (a == "--help" || a == "-h")
    {
      std::cout << kUsage << tools::filterFlagsHelp();
      done = true;
      return o;
    }
    if (a == "--version")
    {
      std::cout << "ecs_node (pcl_ecs) " << PCL_ECS_VERSION_STRING << "\n";
      done = true;
      return o;
    }
    if (a == "--launch")
      applyYaml(value(), o);
    else if (tools::applyFilterFlag(a, value, o.params))
      continue;
    else if (a == "--source")
      o.source = value();
    else if (a == "--sink")
      o.sink = value();
    else if (a == "--queue")
      o.queue = tools::parseUnsignedFlag(a, value());
    else if (a == "--max-frame-bytes")
    {
      const std::string v = value();
      if (!stream::parseByteSize(v, o.max_frame_bytes))
        throw tools::UsageError("--max-frame-bytes: '" + v + "' is not a size (like 64M)");
    }
    else if (a == "--max-bytes-in-flight")
    {
      const std::string v = value();
      if (!stream::parseByteSize(v, o.max_bytes_in_flight))
        throw tools::UsageError("--max-bytes-in-flight: '" + v + "' is not a size (like 1G)");
    }
    else if (a == "--read-timeout")
      o.read_timeout = tools::parseDoubleFlag(a, value());
    else if (a == "--policy")
    {
      const std::string p = value();
      if (p != "block" && p != "drop-oldest")
        throw tools::UsageError("--policy must be block or drop-oldest");
      o.drop_oldest = p == "drop-oldest";
    }
    else if (a == "--workers")
      o.workers = static_cast<int>(tools::parseIntFlag(a, value()));
    else if (a == "--stats-interval")
      o.stats_interval = tools::parseDoubleFlag(a, value());
    else if (a == "--poll-ms")
      o.poll_ms = static_cast<int>(tools::parseIntFlag(a, value()));
    else if (a == "--once")
      o.once = true;
    else if (a == "--quiet" || a == "-q")
      o.quiet = true;
    else
      throw tools::UsageError("unknown option '" + a + "' (see --help)");
  }
  if (o.queue < 1 || o.queue > 100000)
    throw tools::UsageError("queue must be in [1, 100000]");
  if (o.workers < 1 || o.workers > 256)
    throw tools::UsageError("workers must be in [1, 256]");
  if (!(o.stats_interval >= 0.0))
    throw tools::UsageError("stats interval must be >= 0");
  if (!(o.read_timeout >= 0.0 && o.read_timeout <= 86400.0))
    throw tools::UsageError("read timeout must be in [0, 86400] seconds");
  if (o.max_frame_bytes > o.max_bytes_in_flight)
    throw tools::UsageError("--max-frame-bytes (" + std::to_string(o.max_frame_bytes) +
                            ") exceeds --max-bytes-in-flight (" + std::to_string(o.max_bytes_in_flight) +
                            "): a frame of the largest size could never be read");
  if (o.poll_ms < 1 || o.poll_ms > 60000)
    throw tools::UsageError("poll-ms must be in [1, 60000]");
  const std::string why = validate(o.params);
  if (!why.empty())
    throw tools::UsageError(why);
  try
  {
    parseEndpoint(o.source, true);
    parseEndpoint(o.sink, false);
  }
  catch (const std::invalid_argument& e)
  {
    throw tools::UsageError(e.what());
  }
  return o;
}

}  // namespace node
}  // namespace pcl_ecs
