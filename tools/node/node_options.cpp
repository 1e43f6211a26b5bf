// node_options.cpp — ecs_node's launch file and flags (node_options.h).
#include "node_options.h"

#include <pcl_ecs/parameter_table.h>

#include "../common/cli.h"

#include <pcl_ecs/stream/out_of_core.h>
#include <pcl_ecs/version.h>

#include <functional>
#include <iostream>
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
PCD file (any DATA encoding); output frames use the same framing with binary PCD
(docs/NODE_PROTOCOL.md).
A directory source reads *.pcd, *.las and *.laz files in name order once each, when their size has
been stable for one poll (writers should write to a temporary name and rename); a directory sink
writes each output to a temporary name and renames it, so a consumer never sees half a frame. A
LAS / LAZ frame goes to a directory sink as LAS / LAZ under its own name, with its header and every
dimension (docs/LAS.md); to any other sink as binary PCD with every dimension as a field.

)";

namespace
{
/// One of the node's own flags (not the filter's); false when `a` is none of them.
bool applyNodeFlag(const std::string& a, const std::function<std::string()>& value, Options& o)
{
  if (a == "--source")
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
    return false;
  return true;
}

/// The settings checked against each other; throws tools::UsageError.
void checkOptions(const Options& o)
{
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
}
}  // namespace

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
  if (!y.IsMap())
    throw tools::UsageError(path + ": a launch file is a map of option: value");
  // Every key is a flag without its dashes (stats-interval: 5 is --stats-interval 5; once: true is
  // --once); the method's parameters may also sit under filter: (terr: 1.0e-3 is --terr 1.0e-3).
  auto apply = [&](const std::string& key, const YAML::Node& node, bool in_filter) {
    if (!node.IsScalar())
      throw tools::UsageError(path + ": '" + key + "' needs a single value");
    const std::string text = node.as<std::string>();
    if (const ParameterInfo* info = findParameter(key))
    {
      const std::string why = setParameter(*info, text, o.params);
      if (!why.empty())
        throw tools::UsageError(path + ": " + key + ": " + why);
      return;
    }
    if (in_filter || key == "launch")
      throw tools::UsageError(path + ": unknown " + (in_filter ? "filter key '" : "key '") + key + "'");
    if (key == "once" || key == "quiet")
    {
      if (text != "true" && text != "false")
        throw tools::UsageError(path + ": " + key + ": '" + text + "' is not true or false");
      if (text == "false")
        return;
    }
    try
    {
      if (!applyNodeFlag("--" + key, [&] { return text; }, o))
        throw tools::UsageError("unknown key '" + key + "'");
    }
    catch (const tools::UsageError& e)
    {
      throw tools::UsageError(path + ": " + e.what());
    }
  };
  try
  {
    for (const auto& kv : y)
    {
      const std::string key = kv.first.as<std::string>();
      if (key != "filter")
        apply(key, kv.second, false);
      else if (!kv.second.IsMap())
        throw tools::UsageError(path + ": filter: holds the method's parameters (terr: 1.0e-3, ...)");
      else
        for (const auto& f : kv.second)
          apply(f.first.as<std::string>(), f.second, true);
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
    if (tools::printedHelpOrVersion(a, "ecs_node", [] { return kUsage + tools::filterFlagsHelp(); }))
    {
      done = true;
      return o;
    }
    if (a == "--launch")
      applyYaml(value(), o);
    else if (!tools::applyFilterFlag(a, value, o.params) && !applyNodeFlag(a, value, o))
      throw tools::UsageError("unknown option '" + a + "' (see --help)");
  }
  checkOptions(o);
  return o;
}

}  // namespace node
}  // namespace pcl_ecs
