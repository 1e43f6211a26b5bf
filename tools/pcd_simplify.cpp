// pcd_simplify — simplify a scan with the paper's method: feature points kept, everything else
// covered by error-bounded balls, one optimised point per ball.
#include "common/cli.h"
#include "common/mesh_cli.h"
#include "common/cloud_simplify.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/feature_aware_cover_simplify.h>
#include <pcl_ecs/io/cloud_io.h>
#include <pcl_ecs/io/las_io.h>
#include <pcl_ecs/io/pcd_stream.h>
#include <pcl_ecs/io/record_stream.h>
#include <pcl_ecs/stream/out_of_core.h>
#include <pcl_ecs/version.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <limits>
#include <memory>
#include <optional>

#include <nlohmann/json.hpp>
#include <pcl/common/io.h>
#include <pcl/conversions.h>
#include <pcl/console/print.h>

namespace fs = std::filesystem;
using namespace pcl_ecs;
using namespace pcl_ecs::tools;

namespace
{

const char* kUsage = R"(Usage: pcd_simplify INPUT OUTPUT [options]
       pcd_simplify INPUT... OUTPUT --stream [options]   (several files, or a directory of tiles,
                                                          simplified as one cloud)

Simplifies a point cloud while keeping its sharp features: points on sharp edges and corners
(curvature measure above α times the mean) are kept as they are; every other region is covered by
balls as large as the error bound T_err allows, and each ball is replaced by one optimised point.

INPUT   .pcd (ascii, binary, binary_compressed; organised or not), .ply (ascii or binary),
        .las / .laz (LAS 1.0-1.4, point formats 0-10), or plain text .xyz/.txt/.pts/.asc
        (x y z [+ intensity | normals | r g b]).
OUTPUT  .pcd (binary by default), .ply, .las or .laz. Every field of the input is kept (a
        feature point is its input record; a representative is the record of the input point
        it stands for, at its optimised position). LAS in, LAS out: the same version, point
        format, scale, offset and VLRs (the CRS); x y z are rounded to the scale (docs/LAS.md).
        Written to a temporary file beside OUTPUT and renamed into place only on success: a
        failed run leaves no output.

)";

const char* kOptions = R"(Size instead of T_err:
  --target-ratio R    aim at R × the distinct finite input points (coincident points count once:
                      a scan stored twice gives the size it gives once), R in (0, 1]

Scans larger than memory (PCD, LAS or LAZ in and out, PCD binary; docs/STREAMING.md):
  --stream            simplify out of core: the scan is split into tiles (with a halo of
                      neighbours) in a scratch directory and processed tile by tile, two at a
                      time; the statistics the method takes over the whole cloud stay global.
                      Progress on stderr. Killed? Run the same command again: it resumes from
                      the finished tiles. Takes --terr (not a target size); all fields of the
                      input are kept (a LAS / LAZ output keeps a LAS input's header, scale
                      and offset). Output depends on --memory-limit (the tiling), not on
                      --threads. The gap bound (--max-gap) holds across tiles as in memory.
  --memory-limit SIZE memory budget, e.g. 512M, 2G (default: a quarter of the RAM, >= 256M)
  --scratch DIR       scratch directory (default OUTPUT.ecs-scratch); in an existing directory
                      this tool did not make (/tmp, one of yours) it makes NAME.ecs-scratch for
                      an output NAME and removes only that; needs about 150 bytes
                      per input point plus 2.3 × the input's size free (50M points of 17
                      bytes use 4.4 GiB at the peak); removed on success
  --keep-scratch      keep the scratch directory after success, with every intermediate file
                      (by default a tile's files go as soon as no later step reads them)
  --tile-points N     largest tile, own points + halo (default: from --memory-limit); smaller
                      tiles, more of them: for experiments and tests

Output:
  --ascii             write ASCII PCD / PLY
  --compressed        write binary_compressed PCD
  --features FILE     also write the feature points to FILE (.pcd, .ply, .las or .laz, as OUTPUT)
  --labels            add a field 'ecs_label' (uint8): 1 feature, 2 representative; in LAS and LAZ
                      an extra dimension (Extra Bytes VLR: laspy, PDAL, CloudCompare read it)
  --radii             add a field 'ecs_radius' (float; in LAS and LAZ an extra dimension): the
                      radius of the ball each point stands for, 0 for a point kept as it is (a
                      feature point, a gap point); pcd_reconstruct meshes with it as --mesh does
                      (refusing triangles between balls far from overlapping, a point of radius 0
                      judged by its nearest ball)
  --mesh FILE         also triangulate the simplified cloud with Cocone and write the mesh to
                      FILE (.ply, .obj or .vtk); the Cocone flags below tune it
  --stats FILE.json   write what was done: parameters, counts, time per stage, largest error,
                      input and output bounding boxes
  --quiet             print nothing but errors
  --verbose           print the stages and PCL's own messages
  --help              this text
  --version           the version

Exit codes:
  0  success
  1  internal error (please report it)
  2  usage error: unknown flag, bad or out-of-range value, OUTPUT equal to INPUT
  3  input error: missing, unreadable, empty, malformed or truncated file, no finite points,
     fewer points than the neighbourhood, degenerate cloud (all identical, all on a line)
  4  output error: directory missing or not writable, disk full

Examples:
  pcd_simplify scan.pcd small.pcd                      # defaults: T_err 1e-3, α 6
  pcd_simplify scan.pcd small.pcd --terr 5e-4          # finer: more points, smaller error
  pcd_simplify scan.ply small.ply --target-ratio 0.05  # keep about 5% of the points
  pcd_simplify part.pcd out.pcd --alpha 4 --features edges.pcd --labels --stats run.json
  pcd_simplify kinect.pcd out.pcd --compressed         # organised RGB in, unorganised RGB out
  pcd_simplify bunny.pcd small.pcd --mesh small.ply     # simplify, then mesh the result
  pcd_simplify survey.pcd small.pcd --stream --memory-limit 1G --scratch /data/tmp
)";

struct Options
{
  std::string input, output, features, stats, mesh;
  std::vector<std::string> inputs;  // --stream: every input file (a directory: its tiles)
  Parameters params;
  surface::CoconeParameters cocone;
  double target_ratio = 0.0;
  io::Encoding encoding = io::Encoding::Binary;
  bool labels = false, radii = false, quiet = false, verbose = false;
  bool stream = false, keep_scratch = false, encoding_given = false;
  std::uint64_t memory_limit = 0, kill_after = 0, tile_points = 0;
  std::string scratch;
};

Options parseArgs(int argc, char** argv, bool& done)
{
  Options o;
  std::vector<std::string> positional;
  done = false;
  ArgWalker args(argc, argv);
  while (args.next())
  {
    const std::string& a = args.flag();
    auto value = [&]() { return args.value(); };
    if (printedHelpOrVersion(a, "pcd_simplify",
                             [] { return kUsage + filterFlagsHelp() + "\n" + kOptions + "\n" + coconeFlagsHelp(); }))
    {
      done = true;
      return o;
    }
    if (applyFilterFlag(a, value, o.params))
      continue;
    if (applyCoconeFlag(a, value, o.cocone))
      continue;
    if (a == "--target-ratio")
    {
      o.target_ratio = parseDoubleFlag(a, value());
      if (!(o.target_ratio > 0.0 && o.target_ratio <= 1.0))
        throw UsageError("--target-ratio: must be in (0, 1]");
    }
    else if (a == "--ascii")
    {
      o.encoding = io::Encoding::Ascii;
      o.encoding_given = true;
    }
    else if (a == "--compressed")
    {
      o.encoding = io::Encoding::BinaryCompressed;
      o.encoding_given = true;
    }
    else if (a == "--stream")
      o.stream = true;
    else if (a == "--memory-limit")
    {
      const std::string v = value();
      if (!stream::parseByteSize(v, o.memory_limit))
        throw UsageError("--memory-limit: '" + v + "' is not a size (like 512M, 2G)");
      if (o.memory_limit < (64ull << 20))
        throw UsageError("--memory-limit: must be at least 64M");
    }
    else if (a == "--scratch")
      o.scratch = value();
    else if (a == "--keep-scratch")
      o.keep_scratch = true;
    else if (a == "--tile-points")
    {
      o.tile_points = parseUnsignedFlag(a, value());
      if (o.tile_points < 1000)
        throw UsageError("--tile-points: must be at least 1000");
    }
    else if (a == "--debug-kill-after")  // tests: SIGKILL after N tile steps
      o.kill_after = parseUnsignedFlag(a, value());
    else if (a == "--features")
      o.features = value();
    else if (a == "--labels")
      o.labels = true;
    else if (a == "--radii")
      o.radii = true;
    else if (a == "--mesh")
      o.mesh = value();
    else if (a == "--stats")
      o.stats = value();
    else if (a == "--quiet" || a == "-q")
      o.quiet = true;
    else if (a == "--verbose" || a == "-v")
      o.verbose = true;
    else if (a.size() > 1 && a[0] == '-')
      throw UsageError("unknown option '" + a + "' (see --help)");
    else
      positional.push_back(a);
  }
  if (positional.size() != 2 && !(o.stream && positional.size() > 2))
    throw UsageError("expected INPUT and OUTPUT, got " + std::to_string(positional.size()) +
                     " file name(s) (see --help)");
  o.input = positional[0];
  o.output = positional.back();
  if (o.target_ratio > 0.0 && o.params.target_size > 0)
    throw UsageError("--target-size and --target-ratio exclude each other");
  checkFilterFlagConflicts(args, o.target_ratio > 0.0);
  if (o.stream)
  {
    if (o.target_ratio > 0.0 || o.params.target_size > 0)
      throw UsageError("--stream takes --terr, not a target size (see docs/STREAMING.md)");
    if (!o.features.empty() || o.labels || o.radii || !o.mesh.empty() || o.encoding_given)
      throw UsageError("--stream writes one file; --features, --labels, --radii, --mesh, --ascii and "
                       "--compressed are for in-memory runs");
    if (o.params.use_input_normals)
      throw UsageError("--stream estimates the normals; --use-input-normals is for in-memory runs");
    try
    {
      o.inputs = io::recordInputs(std::vector<std::string>(positional.begin(), positional.end() - 1));
    }
    catch (const io::FileError& e)
    {
      throw ToolError(kExitInput, e.what());
    }
    for (const std::string& f : o.inputs)
      if (!io::isRecordFormat(f))
        throw UsageError("--stream reads .pcd, .las and .laz files; " + f + " is not one");
    if (!io::isRecordFormat(o.output))
      throw UsageError("--stream writes .pcd, .las and .laz files; the output is not one");
  }
  else if (o.memory_limit || !o.scratch.empty() || o.keep_scratch || o.kill_after || o.tile_points)
    throw UsageError("--memory-limit, --scratch, --keep-scratch and --tile-points need --stream");
  const std::string why = validate(o.params);
  if (!why.empty())
    throw UsageError(why);
  for (const std::string* out : {&o.output, &o.features})
  {
    if (out->empty())
      continue;
    const io::Format f = io::formatFromPath(*out);
    if (f != io::Format::Pcd && f != io::Format::Ply && f != io::Format::Las && f != io::Format::Laz)
      throw UsageError(*out + ": output must be .pcd, .ply, .las or .laz");
    if (f == io::Format::Laz && !io::lazSupported())
      throw UsageError(*out + ": this build of pcd_simplify has no LAZ support (built with -DPCL_ECS_WITH_LAZ=OFF)");
  }
  if (!o.mesh.empty())
  {
    try
    {
      surface::meshFormatFromPath(o.mesh);
    }
    catch (const std::invalid_argument& e)
    {
      throw UsageError(std::string("--mesh: ") + e.what());
    }
  }
  if (!o.stats.empty() && fs::path(o.stats).extension() != ".json")
    throw UsageError(o.stats + ": --stats writes JSON; give it a .json name");
  // Refuse to overwrite the input with an output, or one output with another.
  std::error_code ec;
  auto sameFile = [&](const std::string& a, const std::string& b) {
    if (fs::exists(a, ec) && fs::exists(b, ec))
      return fs::equivalent(a, b, ec);
    return fs::weakly_canonical(a, ec) == fs::weakly_canonical(b, ec);
  };
  const std::pair<const char*, const std::string*> outputs[] = {
      {"OUTPUT", &o.output}, {"--features", &o.features}, {"--stats", &o.stats}, {"--mesh", &o.mesh}};
  for (std::size_t k = 0; k < std::size(outputs); ++k)
  {
    const std::string& out = *outputs[k].second;
    if (out.empty())
      continue;
    for (const std::string& in : o.inputs.empty() ? std::vector<std::string>{o.input} : o.inputs)
      if (sameFile(in, out))
        throw UsageError(out + (o.inputs.size() > 1 ? ": is one of the input files" : ": is the input file") +
                         "; choose another output name");
    for (std::size_t j = 0; j < k; ++j)
      if (!outputs[j].second->empty() && sameFile(*outputs[j].second, out))
        throw UsageError(std::string(outputs[k].first) + " " + out + " is also " + outputs[j].first +
                         "; give each output its own file");
  }
  return o;
}

nlohmann::json bboxJson(const pcl::PCLPointCloud2& blob)
{
  Eigen::Vector3d lo, hi;
  if (io::boundingBox(blob, lo, hi) == 0)
    return nullptr;
  return {{"min", {lo.x(), lo.y(), lo.z()}}, {"max", {hi.x(), hi.y(), hi.z()}}};
}

/// Memory of an in-memory run per input point besides its records (neighbourhoods, per-point
/// values, the cover; measured: about 180 B at K = 16), with a margin.
constexpr double kInMemoryBytesPerPoint = 250.0;

nlohmann::json statsJson(const Options& o, const CloudRun& run, const pcl::PCLPointCloud2& input)
{
  nlohmann::json j;
  j["tool"] = "pcd_simplify";
  j["version"] = PCL_ECS_VERSION_STRING;
  j["input"] = o.input;
  j["output"] = o.output;
  nlohmann::json fields = nlohmann::json::array();
  for (const auto& f : run.output.fields)
    fields.push_back(f.name);
  j["fields"] = fields;
  j.update(runStatsJson(run.result.summary, o.params, o.target_ratio));
  j["input_bbox"] = bboxJson(input);
  j["output_bbox"] = bboxJson(run.output);
  return j;
}

/// The summary line's note on coincident points ("" when there were none).
std::string mergedNote(std::uint64_t merged)
{
  return merged > 0 ? " (" + std::to_string(merged) + " coincident points merged)" : std::string();
}

/// The summary line's note on the deviation ("" when it was not measured): every input point's
/// distance to the output's surface, in the input's units, and the bound held.
std::string deviationNote(const Summary& s)
{
  if (!s.deviation_measured)
    return {};
  char buf[200];
  std::snprintf(buf, sizeof buf, "; deviation max %.3g (p99 %.3g, RMS %.3g)", s.deviation_max, s.deviation_p99,
                s.deviation_rms);
  std::string note = buf;
  if (s.max_deviation > 0.0)
  {
    std::snprintf(buf, sizeof buf, " <= %.3g, %zu points added to hold it", s.max_deviation, s.deviation_points);
    note += buf;
  }
  return note;
}

/// The extra dimensions --labels and --radii add to a LAS or LAZ output, and the fields they come
/// from (simplifyCloud appends them: ecs_label uint8, ecs_radius float).
std::vector<io::ExtraDimension> lasExtraDimensions(const Options& o, std::vector<pcl::PCLPointField>* fields = nullptr)
{
  std::vector<io::ExtraDimension> dims;
  auto add = [&](const char* name, std::uint8_t datatype, const char* description) {
    dims.push_back({name, description});
    if (fields)
    {
      pcl::PCLPointField f;
      f.name = name;
      f.datatype = datatype;
      f.count = 1;
      fields->push_back(f);
    }
  };
  if (o.labels)
    add("ecs_label", pcl::PCLPointField::UINT8, "pcl_ecs: 1 feature, 2 ball");
  if (o.radii)
    add("ecs_radius", pcl::PCLPointField::FLOAT32, "pcl_ecs: radius of its ball");
  return dims;
}

int runStream(const Options& o)
{
  stream::StreamOptions so;
  so.memory_limit = o.memory_limit;
  so.scratch_dir = o.scratch;
  so.keep_scratch = o.keep_scratch;
  so.kill_after_steps = o.kill_after;
  so.max_tile_points = o.tile_points;
  if (!o.quiet)
    so.progress = [](const std::string& line) { std::fprintf(stderr, "pcd_simplify: %s\n", line.c_str()); };
  stream::StreamSummary s;
  try
  {
    s = stream::simplifyOutOfCore(o.inputs, o.output, o.params, so);
  }
  catch (const stream::LimitError& e)
  {
    throw ToolError(kExitUsage, e.what());
  }
  catch (const io::FormatError& e)
  {
    throw ToolError(kExitInput, e.what());
  }
  catch (const io::FileError& e)
  {
    const bool is_output = std::string(e.what()).rfind(o.output, 0) == 0;
    throw ToolError(is_output ? kExitOutput : kExitInput, e.what());
  }
  catch (const std::filesystem::filesystem_error& e)
  {
    throw ToolError(kExitOutput, std::string("scratch space: ") + e.what());
  }
  catch (const std::runtime_error& e)
  {
    const std::string what = e.what();
    const bool input = what.rfind(o.input, 0) == 0;
    throw ToolError(input ? kExitInput : kExitOutput, what);
  }
  if (!o.stats.empty())
  {
    io::AtomicOutput out(o.stats);
    std::ofstream js(out.tempPath());
    nlohmann::json j;
    j["tool"] = "pcd_simplify --stream";
    j["version"] = PCL_ECS_VERSION_STRING;
    j["input"] = o.input;
    j["output"] = o.output;
    j["parameters"] = parametersJson(o.params);
    j["parameters"]["memory-limit"] = o.memory_limit;
    j["counts"] = {{"input_points", s.input_points}, {"finite_points", s.finite_points},
                   {"merged_points", s.merged_points},
                   {"feature_points", s.feature_points}, {"balls", s.balls},
                   {"gap_points", s.gap_points},         {"output_points", s.output_points}};
    j["geometry"] = {{"bbox_diagonal", s.bbox_diagonal},         {"feature_threshold", s.feature_threshold},
                     {"mean_spacing", s.mean_spacing},           {"neighborhood_radius", s.neighborhood_radius},
                     {"mean_abs_curvature", s.mean_abs_curvature}, {"max_error", s.max_error},
                     {"halo", s.halo}};
    nlohmann::json tiles = nlohmann::json::array();
    for (const auto& t : s.tiles)
      tiles.push_back({{"lo", {t.lo[0], t.lo[1]}}, {"hi", {t.hi[0], t.hi[1]}}, {"core_points", t.core_points},
                       {"halo_points", t.halo_points}, {"colour", t.colour}});
    j["tiles"] = {{"axes", {s.axis_u, s.axis_v}}, {"tile_point_budget", s.tile_point_budget}, {"list", tiles},
                  {"incomplete_neighbourhoods", s.incomplete_neighbourhoods},
                  {"split_runs", s.split_runs},
                  {"halo_too_narrow", s.halo_too_narrow}};
    j["scratch_bytes"] = s.scratch_bytes;
    j["resumed"] = s.resumed;
    j["timings_s"] = {{"scan", s.stage_seconds[0]}, {"split", s.stage_seconds[1]}, {"phase_a", s.stage_seconds[2]},
                      {"phase_b", s.stage_seconds[3]}, {"phase_c", s.stage_seconds[4]}, {"write", s.stage_seconds[5]},
                      {"total", s.seconds}};
    js << j.dump(2) << "\n";
    js.flush();
    if (!js)
      throw ToolError(kExitOutput, o.stats + ": write error");
    js.close();
    out.commit();
  }
  if (!o.quiet)
    std::printf("%s: %llu -> %llu points (%.2f%%)%s: %llu features, %llu balls; T_err %.3g, max error %.3g L; "
                "%zu tiles; %.2f s (%.2f M points/s)\n",
                o.output.c_str(), static_cast<unsigned long long>(s.finite_points),
                static_cast<unsigned long long>(s.output_points),
                100.0 * static_cast<double>(s.output_points) / static_cast<double>(std::max<std::uint64_t>(1, s.finite_points)),
                mergedNote(s.merged_points).c_str(), static_cast<unsigned long long>(s.feature_points), static_cast<unsigned long long>(s.balls),
                o.params.error_threshold, s.max_error, s.tiles.size(), s.seconds,
                static_cast<double>(s.input_points) / std::max(1e-9, s.seconds) / 1e6);
  return kExitOk;
}

int runTool(int argc, char** argv)
{
  bool done = false;
  const Options o = parseArgs(argc, argv, done);
  if (done)
    return kExitOk;
  if (o.stream)
  {
    if (!o.stats.empty())
    {
      const std::string why = io::checkWritable(o.stats);
      if (!why.empty())
        throw ToolError(kExitOutput, o.stats + ": " + why);
    }
    return runStream(o);
  }
  pcl::console::setVerbosityLevel(o.verbose ? pcl::console::L_INFO : pcl::console::L_ALWAYS);

  // Fail early on outputs that cannot be written, before any long work.
  for (const std::string* out : {&o.output, &o.features, &o.stats, &o.mesh})
    if (!out->empty())
    {
      const std::string why = io::checkWritable(*out);
      if (!why.empty())
        throw ToolError(kExitOutput, *out + ": " + why);
    }

  // A PCD's header says how many points it holds: a cloud this machine cannot hold in memory (or a
  // header that claims one) is refused before anything is allocated.
  // The header says how large the cloud is: one that cannot fit, or that the file cannot hold, is
  // refused before the file is read whole.
  {
    io::CloudProbe probe;
    try
    {
      probe = io::probeCloud(o.input);
    }
    catch (const io::FormatError& e)
    {
      // A header line too long to be one, or a body the file cannot hold, is refused here; any
      // other problem is said by the full read below, as for any file.
      const std::string what = e.what();
      if (what.find("KiB: not a P") != std::string::npos || what.find("truncated") != std::string::npos)
        throw ToolError(kExitInput, what);
    }
    const double need = static_cast<double>(probe.points) *
                        (kInMemoryBytesPerPoint + 3.0 * static_cast<double>(probe.point_step));
    const double available = static_cast<double>(stream::availableMemory());
    if (available > 0.0 && need > available)
    {
      char line[400];
      std::snprintf(line, sizeof line,
                    "%s: %llu points need about %.1f GiB in memory; %.1f GiB are available%s",
                    o.input.c_str(), static_cast<unsigned long long>(probe.points), need / (1u << 30),
                    available / (1u << 30),
                    io::isRecordFormat(o.input) ? ": use --stream (docs/STREAMING.md)" : "");
      throw ToolError(kExitInput, line);
    }
  }
  pcl::PCLPointCloud2 input;
  io::LasInfo las;  // the input's LAS header, kept for a LAS / LAZ output
  bool input_is_las = false;
  try
  {
    input_is_las = io::readCloud(o.input, input, &las);
  }
  catch (const std::exception& e)
  {
    throw ToolError(kExitInput, e.what());
  }
  // A LAS or LAZ output of these records must be possible before the work starts: with the
  // extra dimensions of --labels and --radii, and as LAZ.
  const bool output_is_las = io::formatFromPath(o.output) == io::Format::Las || io::formatFromPath(o.output) == io::Format::Laz;
  const std::vector<io::ExtraDimension> extra_dims = output_is_las ? lasExtraDimensions(o) : std::vector<io::ExtraDimension>();
  for (const std::string* out : {&o.output, &o.features})
    if (input_is_las && !out->empty())
    {
      io::LasInfo written = las;
      if (out == &o.output && !extra_dims.empty())
        try
        {
          std::vector<pcl::PCLPointField> fields;
          lasExtraDimensions(o, &fields);
          io::addLasExtraDimensions(written, fields, extra_dims);
        }
        catch (const io::FormatError& e)
        {
          throw ToolError(kExitOutput, *out + ": " + o.input + ": --labels / --radii: " + e.what());
        }
      if (io::formatFromPath(*out) == io::Format::Laz)
        if (const std::string why = io::lazCannotWrite(written); !why.empty())
          throw ToolError(kExitOutput, *out + ": " + o.input + ": " + why);
    }
  if (o.params.use_input_normals && (io::fieldIndex(input.fields, "normal_x") < 0 ||
                                     io::fieldIndex(input.fields, "normal_y") < 0 ||
                                     io::fieldIndex(input.fields, "normal_z") < 0))
    throw ToolError(kExitInput, o.input + ": --use-input-normals given but the file has no normals");

  ProgressLine progress("pcd_simplify", !o.quiet && stderrIsTerminal());
  CloudRunOptions run_options;
  run_options.target_ratio = o.target_ratio;
  run_options.features = !o.features.empty();
  run_options.labels = o.labels;
  run_options.radii = o.radii;
  run_options.progress = progress.callback();
  const CloudRun r = simplifyCloud(input, o.params, run_options);
  progress.finish();
  if (!r.result.error.empty())
  {
    const bool internal = r.result.error.rfind("internal error", 0) == 0;
    throw ToolError(internal ? kExitInternal : kExitInput, o.input + ": " + r.result.error);
  }

  // The surface of the simplified cloud, when asked for: nothing is written if it fails.
  std::optional<MeshRun> mesh;
  if (!o.mesh.empty())
  {
    mesh = meshCloud(r.output, o.cocone, pointRadii(r.result),
                     o.cocone.open_tunnels ? scanSupport(input, r.result.input_to_output) : surface::ScanSupport{});
    if (!mesh->result.ok())
      throw ToolError(kExitInput, o.input + ": the simplified cloud cannot be meshed: " + mesh->result.error);
  }

  // Write everything to temporaries, then rename all into place.
  std::vector<std::unique_ptr<io::AtomicOutput>> outputs;
  try
  {
    outputs.push_back(std::make_unique<io::AtomicOutput>(o.output));
    if (extra_dims.empty())
      io::writeCloud(outputs.back()->tempPath(), io::formatFromPath(o.output), r.output, o.encoding,
                     input_is_las ? &las : nullptr);
    else
    {
      io::LasInfo with_dims = io::lasInfoFor(r.output, input_is_las ? &las : nullptr);
      io::addLasExtraDimensions(with_dims, r.output.fields, extra_dims);
      io::writeCloud(outputs.back()->tempPath(), io::formatFromPath(o.output), r.output, o.encoding, &with_dims);
    }
    if (!o.features.empty())
    {
      outputs.push_back(std::make_unique<io::AtomicOutput>(o.features));
      io::writeCloud(outputs.back()->tempPath(), io::formatFromPath(o.features), r.features, o.encoding,
                     input_is_las ? &las : nullptr);
    }
    if (mesh)
    {
      outputs.push_back(std::make_unique<io::AtomicOutput>(o.mesh));
      writeMeshFile(outputs.back()->tempPath(), surface::meshFormatFromPath(o.mesh), *mesh);
    }
    if (!o.stats.empty())
    {
      outputs.push_back(std::make_unique<io::AtomicOutput>(o.stats));
      std::ofstream js(outputs.back()->tempPath());
      nlohmann::json j = statsJson(o, r, input);
      if (mesh)
      {
        j["mesh"] = meshStatsJson(*mesh, o.cocone);
        j["mesh"]["file"] = o.mesh;
      }
      js << j.dump(2) << "\n";
      js.flush();
      if (!js)
        throw io::FileError(o.stats + ": write error");
    }
    for (auto& out : outputs)
      out->commit();
  }
  catch (const io::FileError& e)
  {
    throw ToolError(kExitOutput, e.what());
  }
  catch (const io::FormatError& e)  // a cloud the output format cannot hold (LAS: a coordinate past its scale)
  {
    throw ToolError(kExitOutput, o.output + ": " + e.what());
  }

  if (!r.result.summary.target_reached)
    std::fprintf(stderr,
                 "pcd_simplify: warning: the target of %zu points is out of reach; the closest size is %zu points "
                 "(%s)\n",
                 r.result.summary.target_size, r.result.summary.output_points,
                 r.result.summary.output_points > r.result.summary.target_size
                     ? "every ball is already as large as the radius cap allows (--radius-cap, --target-cap)"
                     : "every point is already a feature or a ball of its own");
  if (!o.quiet)
  {
    const Summary& s = r.result.summary;
    const std::string thinned =
        s.thinned_features > 0 ? " (" + std::to_string(s.thinned_features) + " more thinned along the edges)" : "";
    std::printf("%s: %zu -> %zu points (%.2f%%)%s: %zu features%s, %zu balls; T_err %.3g, max error "
                "%.3g L%s; %.2f s\n",
                o.output.c_str(), s.finite_points, s.output_points,
                100.0 * static_cast<double>(s.output_points) / static_cast<double>(std::max<std::size_t>(1, s.finite_points)),
                mergedNote(s.merged_points).c_str(), s.feature_points, thinned.c_str(), s.balls, s.error_threshold, s.max_error,
                deviationNote(s).c_str(), s.timings.total);
    if (mesh)
      std::printf("%s: %s\n", o.mesh.c_str(), meshSummaryLine(*mesh).c_str());
  }
  if (o.verbose)
  {
    const StageTimings& t = r.result.summary.timings;
    std::fprintf(stderr,
                 "stages (s): neighbours %.3f normals %.3f weights %.3f features %.3f density %.3f "
                 "curvature %.3f cover %.3f deviation %.3f output %.3f\n",
                 t.neighbors, t.normals, t.weights, t.features, t.density, t.curvature, t.cover, t.deviation,
                 t.output);
  }
  return kExitOk;
}

}  // namespace

int main(int argc, char** argv)
{
  keepFreedMemory();
  io::removeTemporariesOnSignal();  // an interrupted run leaves no temporary file
  return runToolMain("pcd_simplify", [&] { return runTool(argc, argv); });
}
