// Integration tests of the pcd_simplify binary: real runs on the shared scans, the target-size
// mode, attributes, the stats file, and every bad input with its exit code and no output left.
#include "cli_fixture.h"

#include <pcl_ecs/parameter_table.h>

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/io/cloud_io.h>
#include <pcl_ecs/io/las_io.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstring>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <Eigen/Eigenvalues>
#include <pcl/kdtree/kdtree_flann.h>
#include <nlohmann/json.hpp>
#include <pcl/common/io.h>
#include <pcl/conversions.h>
#include <pcl/point_types.h>

namespace fs = std::filesystem;

namespace
{
const std::string kTool = PCD_SIMPLIFY_PATH;
const std::string kShared = PCL_ECS_SHARED_DATA_DIR;

using pcl_ecs_test::RunResult;
using pcl_ecs_test::slurp;

class Cli : public pcl_ecs_test::TempDirTest
{
protected:
  RunResult run(const std::string& args) const { return runTool(kTool, args); }

  void write(const std::string& name, const std::string& content) const
  {
    std::ofstream(path(name), std::ios::binary) << content;
  }

  /// Nothing but the inputs in the directory: no output, no temporary left behind.
  void expectNoOutput(const std::set<std::string>& inputs) const
  {
    for (const auto& e : fs::directory_iterator(dir_))
      EXPECT_TRUE(inputs.count(e.path().filename().string())) << "left behind: " << e.path();
  }

  void expectRefused(const std::string& args, int code, const std::set<std::string>& inputs,
                     const std::string& message_part)
  {
    const RunResult r = run(args);
    EXPECT_EQ(r.code, code) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(message_part), std::string::npos) << "stderr: " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line expected: " << r.err;
    expectNoOutput(inputs);
  }
};

pcl::PCLPointCloud2 load(const std::string& p)
{
  pcl::PCLPointCloud2 c;
  pcl_ecs::io::readCloud(p, c);
  return c;
}

std::string pcdHeader(const std::string& fields, const std::string& size, const std::string& type,
                      std::size_t points, const std::string& data)
{
  std::ostringstream os;
  os << "VERSION 0.7\nFIELDS " << fields << "\nSIZE " << size << "\nTYPE " << type
     << "\nWIDTH " << points << "\nHEIGHT 1\nPOINTS " << points << "\nDATA " << data << "\n";
  return os.str();
}

std::string asciiPcd(const std::vector<std::array<float, 3>>& pts)
{
  std::ostringstream os;
  os << pcdHeader("x y z", "4 4 4", "F F F", pts.size(), "ascii");
  for (const auto& p : pts)
    os << p[0] << " " << p[1] << " " << p[2] << "\n";
  return os.str();
}
}  // namespace

TEST_F(Cli, RunsOnEverySharedScan)
{
  for (const char* name : {"bunny.pcd", "bun000_rangescan.pcd", "fandisk_scan.pcd",
                           "table_scene_mug_organized.pcd", "terrain_csite1_utm.pcd",
                           "bunny_mesh.ply", "fandisk_mesh.ply"})
  {
    const std::string in = kShared + "/" + name;
    const std::string out = path(std::string("out_") + name);
    const RunResult r = run(in + " " + out + " --quiet");
    ASSERT_EQ(r.code, 0) << name << ": " << r.err;
    EXPECT_TRUE(r.out.empty());
    const auto input = load(in);
    const auto output = load(out);
    EXPECT_GT(output.width, 0u) << name;
    EXPECT_LT(output.width, input.width * input.height / 2) << name;
    EXPECT_EQ(output.height, 1u);
  }
}

TEST_F(Cli, TargetSizeAndRatio)
{
  const std::string in = kShared + "/fandisk_scan.pcd";
  RunResult r = run(in + " " + path("a.pcd") + " --target-size 6000 -q");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NEAR(load(path("a.pcd")).width, 6000.0, 60.0);
  r = run(in + " " + path("b.ply") + " --target-ratio 0.03 -q");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NEAR(load(path("b.ply")).width, 3600.0, 36.0);
}

TEST_F(Cli, ColourOfTheOrganisedKinectCloudSurvives)
{
  const std::string in = kShared + "/table_scene_mug_organized.pcd";
  for (const char* out : {"mug.pcd", "mug.ply"})
  {
    const RunResult r = run(in + " " + path(out) + " -q --labels");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto input = load(in);
    const auto output = load(path(out));
    pcl::PointCloud<pcl::PointXYZRGB> a, b;
    pcl_ecs::io::fromCloud(input, a);
    pcl_ecs::io::fromCloud(output, b);
    std::set<std::uint32_t> colours;
    for (const auto& p : a)
      colours.insert(p.rgba & 0xFFFFFFu);
    std::size_t real = 0, non_grey = 0;
    for (const auto& p : b)
    {
      real += colours.count(p.rgba & 0xFFFFFFu);
      non_grey += (p.r != p.g || p.g != p.b);
    }
    EXPECT_EQ(real, b.size()) << "every colour must be a real input colour";
    EXPECT_GT(non_grey, b.size() / 10);
    EXPECT_TRUE(std::any_of(output.fields.begin(), output.fields.end(),
                            [](const auto& f) { return f.name == "ecs_label"; }));
  }
}

TEST_F(Cli, StatsAgreeWithTheOutputAndFeaturesFile)
{
  const std::string in = kShared + "/fandisk_scan.pcd";
  const RunResult r = run(in + " " + path("o.pcd") + " --stats " + path("s.json") + " --features " +
                          path("f.pcd") + " --alpha 5 --ascii");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("->"), std::string::npos);
  const auto j = nlohmann::json::parse(slurp(path("s.json")));
  const auto out = load(path("o.pcd"));
  const auto feats = load(path("f.pcd"));
  EXPECT_EQ(j["counts"]["output_points"].get<std::size_t>(), out.width);
  EXPECT_EQ(j["counts"]["feature_points"].get<std::size_t>(), feats.width);
  EXPECT_EQ(j["counts"]["feature_points"].get<std::size_t>() + j["counts"]["balls"].get<std::size_t>(), out.width);
  EXPECT_EQ(j["counts"]["input_points"].get<std::size_t>(), 120000u);
  EXPECT_DOUBLE_EQ(j["parameters"]["alpha"].get<double>(), 5.0);
  EXPECT_LE(j["geometry"]["max_error"].get<double>(), 2.0 * j["parameters"]["terr"].get<double>());
  // Every parameter under its flag's spelling, and --help lists every one.
  const RunResult help = run("--help");
  for (const pcl_ecs::ParameterInfo& info : pcl_ecs::parameterTable())
  {
    EXPECT_TRUE(j["parameters"].contains(info.name)) << info.name;
    EXPECT_NE(help.out.find(std::string("--") + info.name + (*info.metavar ? " " : "")), std::string::npos) << info.name;
  }
  EXPECT_EQ(j["parameters"]["no-adapt"].get<bool>(), false);
  EXPECT_GT(j["timings_s"]["total"].get<double>(), 0.0);
  // The output's bounding box lies within the input's (grown by a ball radius at most).
  for (int k = 0; k < 3; ++k)
  {
    EXPECT_GE(j["output_bbox"]["min"][k].get<double>(), j["input_bbox"]["min"][k].get<double>() - 0.1);
    EXPECT_LE(j["output_bbox"]["max"][k].get<double>(), j["input_bbox"]["max"][k].get<double>() + 0.1);
  }
  EXPECT_NE(slurp(path("o.pcd")).find("DATA ascii"), std::string::npos);
}

TEST_F(Cli, HelpAndVersion)
{
  RunResult r = run("--help");
  EXPECT_EQ(r.code, 0);
  for (const char* s : {"--terr", "--alpha", "--k", "--target-size", "--target-ratio", "--seed",
                        "--threads", "--features", "--labels", "--stats", "Exit codes", "Examples"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s;
  // Within 100 columns, as a terminal shows it.
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);)
    EXPECT_LE(line.size(), 100u) << line;
  r = run("--version");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("pcl_ecs"), std::string::npos);
}

TEST_F(Cli, BadFilesAreRefusedWithExitCode3AndNoOutput)
{
  write("empty.pcd", "");
  write("text.pcd", "hello, I am not a point cloud\n");
  write("text.ply", "hello\n");
  write("truncated.pcd", pcdHeader("x y z", "4 4 4", "F F F", 1000, "binary") + std::string(400, '\0'));
  write("inconsistent.pcd", pcdHeader("x y z", "4 4", "F F F", 10, "ascii") + "1 2 3\n");
  write("novertex.ply", "ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n");
  std::ostringstream nan;
  nan << pcdHeader("x y z", "4 4 4", "F F F", 50, "ascii");
  for (int i = 0; i < 50; ++i)
    nan << "nan nan nan\n";
  write("allnan.pcd", nan.str());
  std::vector<std::array<float, 3>> few, same, line, mostly_nan;
  for (int i = 0; i < 10; ++i)
    few.push_back({float(i), float(i * i % 7), 0.5f * i});
  for (int i = 0; i < 100; ++i)
    same.push_back({1.f, 2.f, 3.f});
  for (int i = 0; i < 100; ++i)
    line.push_back({0.1f * i, 0.2f * i, 0.3f * i});
  write("few.pcd", asciiPcd(few));
  write("same.pcd", asciiPcd(same));
  write("line.pcd", asciiPcd(line));
  std::ostringstream mn;
  mn << pcdHeader("x y z", "4 4 4", "F F F", 1000, "ascii");
  for (int i = 0; i < 1000; ++i)
    mn << (i % 100 == 0 ? std::to_string(i) + " 1 " + std::to_string(i % 3) : std::string("nan inf nan")) << "\n";
  write("mostlynan.pcd", mn.str());
  fs::create_directory(path("adir.pcd"));
  const std::set<std::string> inputs = {"empty.pcd", "text.pcd", "text.ply", "truncated.pcd",
                                        "inconsistent.pcd", "novertex.ply", "allnan.pcd", "few.pcd",
                                        "same.pcd", "line.pcd", "mostlynan.pcd", "adir.pcd"};
  const std::string out = " " + path("out.pcd");
  expectRefused(path("missing.pcd") + out, 3, inputs, "no such file");
  expectRefused(path("adir.pcd") + out, 3, inputs, "is a directory");
  expectRefused(path("empty.pcd") + out, 3, inputs, "empty");
  expectRefused(path("text.pcd") + out, 3, inputs, "not a PCD header");
  expectRefused(path("text.ply") + out, 3, inputs, "not a PLY file");
  expectRefused(path("truncated.pcd") + out, 3, inputs, "truncated");
  expectRefused(path("inconsistent.pcd") + out, 3, inputs, "inconsistent");
  expectRefused(path("novertex.ply") + out, 3, inputs, "no vertices");
  expectRefused(path("allnan.pcd") + out, 3, inputs, "no finite points");
  expectRefused(path("few.pcd") + out, 3, inputs, "K = 16");
  expectRefused(path("same.pcd") + out, 3, inputs, "identical");
  expectRefused(path("line.pcd") + out, 3, inputs, "line");
  expectRefused(path("mostlynan.pcd") + out, 3, inputs, "only 10 finite points");
  expectRefused(path("text.pcd") + " " + path("out.xyz"), 2, inputs, "must be .pcd, .ply, .las or .laz");
  // Unreadable, even for root (CI runs as root, which ignores file permissions): a name that
  // leads to /proc/self/mem, whose first page cannot be read.
  fs::create_symlink("/proc/self/mem", path("unreadable.pcd"));
  auto with_unreadable = inputs;
  with_unreadable.insert("unreadable.pcd");
  expectRefused(path("unreadable.pcd") + out, 3, with_unreadable, "cannot be read");
}

TEST_F(Cli, BadParametersAreUsageErrors)
{
  const std::string in = kShared + "/bunny.pcd";
  const std::string out = " " + path("out.pcd");
  const std::set<std::string> none;
  expectRefused(in + out + " --terr -1", 2, none, "error_threshold");
  expectRefused(in + out + " --terr 0", 2, none, "error_threshold");
  expectRefused(in + out + " --terr nan", 2, none, "--terr");
  expectRefused(in + out + " --terr abc", 2, none, "not a number");
  expectRefused(in + out + " --alpha 0", 2, none, "feature_factor");
  expectRefused(in + out + " --k 3", 2, none, "k_neighbors");
  expectRefused(in + out + " --k 1e9", 2, none, "--k");
  expectRefused(in + out + " --threads -2", 2, none, "threads = -2 is invalid");
  expectRefused(in + out + " --radius-cap 0", 2, none, "radius_cap_factor");
  expectRefused(in + out + " --adapt-factor 0.5", 2, none, "adaptive_factor");
  expectRefused(in + out + " --rep-offset 0", 2, none, "max_representative_offset");
  expectRefused(in + out + " --rep-cutoff 1.5", 2, none, "representative_cutoff");
  expectRefused(in + out + " --max-roughness 0", 2, none, "max_roughness");
  expectRefused(in + out + " --error-form fancy", 2, none, "--error-form");
  expectRefused(in + out + " --target-ratio 1.5", 2, none, "--target-ratio");
  expectRefused(in + out + " --target-size 0", 2, none, "--target-size");
  expectRefused(in + out + " --bogus", 2, none, "unknown option");
  expectRefused(in, 2, none, "expected INPUT and OUTPUT");
  expectRefused(in + out + " --terr", 2, none, "needs a value");
}

TEST_F(Cli, OutputProblemsAreRefusedBeforeAnyWork)
{
  const std::string in = kShared + "/bunny.pcd";
  std::set<std::string> none;
  expectRefused(in + " " + path("no/such/dir/out.pcd"), 4, none, "does not exist");
  write("afile", "x");
  none.insert("afile");
  expectRefused(in + " " + path("afile/out.pcd"), 4, none, "does not exist");
  // Output equal to input: refused, and the input is untouched.
  const std::string copy = path("copy.pcd");
  fs::copy_file(in, copy);
  none.insert("copy.pcd");
  const auto before = slurp(copy);
  expectRefused(copy + " " + copy, 2, none, "is the input file");
  expectRefused(copy + " " + path("o.pcd") + " --stats " + copy, 2, none, ".json");
  EXPECT_EQ(slurp(copy), before);
}

namespace
{
/// Per point of `c`: its ecs_label and ecs_radius fields as bytes (a LAS or LAZ file's extra
/// dimensions are read as such fields).
std::vector<std::array<std::uint8_t, 5>> labelsAndRadii(const pcl::PCLPointCloud2& c)
{
  std::vector<std::array<std::uint8_t, 5>> v(static_cast<std::size_t>(c.width) * c.height);
  const int fl = pcl_ecs::io::fieldIndex(c.fields, "ecs_label"), fr = pcl_ecs::io::fieldIndex(c.fields, "ecs_radius");
  if (fl < 0 || fr < 0)
  {
    ADD_FAILURE() << "no ecs_label and ecs_radius fields";
    return {};
  }
  for (std::size_t i = 0; i < v.size(); ++i)
  {
    const std::uint8_t* rec = c.data.data() + i * c.point_step;
    v[i][0] = rec[c.fields[static_cast<std::size_t>(fl)].offset];
    std::memcpy(&v[i][1], rec + c.fields[static_cast<std::size_t>(fr)].offset, 4);
  }
  return v;
}
}  // namespace

// --labels and --radii with a LAS or LAZ output: extra dimensions after the records' own extra
// bytes, read back as fields holding what the PCD output's fields hold; a LAS output of ours
// simplified again gets its dimensions written over (the records do not grow). An input whose
// Extra Bytes VLR cannot be extended is refused before any work (exit 4); without the flags it
// passes through.
TEST_F(Cli, LabelsAndRadiiInLasAndLazAreExtraDimensions)
{
  namespace io = pcl_ecs::io;
  const std::string in = kShared + "/fandisk_scan.pcd ";
  const std::string flags = " --target-ratio 0.1 --labels --radii --quiet";
  std::vector<std::string> outs = {"out.pcd", "out.las"};
  if (io::lazSupported())
    outs.push_back("out.laz");
  for (const std::string& out : outs)
  {
    const RunResult r = run(in + path(out) + flags);
    ASSERT_EQ(r.code, 0) << out << ": " << r.err;
  }
  const auto want = labelsAndRadii(load(path("out.pcd")));
  std::size_t features = 0;
  for (const auto& v : want)
    features += v[0] == 1 ? 1 : 0;
  EXPECT_GT(features, 0u);
  EXPECT_LT(features, want.size());
  for (const std::string& out : outs)
  {
    if (out == "out.pcd")
      continue;
    pcl::PCLPointCloud2 c;
    io::LasInfo info;
    io::readCloud(path(out), c, &info);
    EXPECT_EQ(info.record_length, io::lasStandardRecordLength(info.point_format) + 5) << out;
    EXPECT_EQ(labelsAndRadii(c), want) << out;
  }

  // Simplified again: to LAS with the flags, and to PCD with them (the reference: the LAS input's
  // 5 extra bytes as a field, the new labels and radii as fields).
  const std::string again = path("out.las") + " ";
  ASSERT_EQ(run(again + path("again.las") + flags).code, 0);
  ASSERT_EQ(run(again + path("again.pcd") + flags).code, 0);
  pcl::PCLPointCloud2 las_again;
  io::LasInfo info_again;
  io::readCloud(path("again.las"), las_again, &info_again);
  EXPECT_EQ(info_again.record_length, io::lasStandardRecordLength(info_again.point_format) + 5);
  const auto want_again = labelsAndRadii(load(path("again.pcd")));
  EXPECT_EQ(labelsAndRadii(las_again), want_again);
  EXPECT_LT(want_again.size(), want.size());

  // An Extra Bytes VLR that is not whole descriptors: refused before any work with the flags.
  pcl::PCLPointCloud2 read;
  io::LasInfo info;
  io::readCloud(path("out.las"), read, &info);
  for (io::LasVlr& v : info.vlrs)
    if (v.user_id == "LASF_Spec" && v.record_id == 4)
      v.data.resize(100);
  write("bad_vlr.las", io::lasBytes(read, &info, false));
  const std::set<std::string> inputs = {"out.pcd", "out.las", "out.laz", "again.las", "again.pcd", "bad_vlr.las"};
  expectRefused(path("bad_vlr.las") + " " + path("o.las") + " --labels", 4, inputs, "192-byte");
  const RunResult plain = run(path("bad_vlr.las") + " " + path("o.las") + " --quiet");
  EXPECT_EQ(plain.code, 0) << plain.err;
}

// LAS records with more extra bytes than LAZ holds (io::lazMaxExtraBytes()): a LAZ output (or
// features file) is refused before the work, in memory and streamed, with nothing written; LAS
// takes them.
TEST_F(Cli, ALazOutputOfRecordsWithTooManyExtraBytesIsRefusedBeforeAnyWork)
{
  if (!pcl_ecs::io::lazSupported())
    GTEST_SKIP() << "built without LAZ";
  pcl::PCLPointCloud2 bunny, read;
  pcl_ecs::io::readCloud(kShared + "/bunny.pcd", bunny);
  pcl_ecs::io::LasInfo info;
  pcl_ecs::io::parseLas(pcl_ecs::io::lasBytes(bunny, nullptr, false), read, &info);
  info.record_length = static_cast<std::uint16_t>(pcl_ecs::io::lasStandardRecordLength(info.point_format) +
                                                  pcl_ecs::io::lazMaxExtraBytes() + 1);
  write("wide.las", pcl_ecs::io::lasBytes(read, &info, false));
  const std::set<std::string> inputs = {"wide.las"};
  const std::string in = path("wide.las") + " ";
  expectRefused(in + path("out.laz"), 4, inputs, "1025 extra bytes");
  expectRefused(in + path("out.las") + " --features " + path("f.laz"), 4, inputs, "1025 extra bytes");
  expectRefused(in + path("out.laz") + " --stream", 4, inputs, "1025 extra bytes");
  const RunResult r = run(in + path("out.las") + " --quiet");
  EXPECT_EQ(r.code, 0) << r.err;
  pcl::PCLPointCloud2 out;
  pcl_ecs::io::LasInfo out_info;
  pcl_ecs::io::readCloud(path("out.las"), out, &out_info);
  EXPECT_EQ(out_info.record_length, info.record_length);
  EXPECT_GT(out.width, 0u);
}

TEST_F(Cli, ReadsEveryEncoding)
{
  // The same cloud as PCD ascii / binary / binary_compressed, PLY ascii / binary and XYZ gives the
  // same output.
  const std::string in = kShared + "/bunny.pcd";
  ASSERT_EQ(run(in + " " + path("ref.pcd") + " -q").code, 0);
  const auto ref = load(path("ref.pcd"));
  const auto bunny = load(in);
  pcl::PointCloud<pcl::PointXYZ> pts;
  pcl_ecs::io::fromCloud(bunny, pts);
  std::ostringstream xyz;
  xyz.precision(9);
  for (const auto& p : pts)
    xyz << p.x << " " << p.y << " " << p.z << "\n";
  write("bunny.xyz", xyz.str());
  std::vector<std::string> variants = {path("bunny.xyz")};
  using pcl_ecs::io::Encoding;
  for (auto [name, enc] : {std::pair{"ascii.pcd", Encoding::Ascii}, std::pair{"binary.pcd", Encoding::Binary},
                           std::pair{"compressed.pcd", Encoding::BinaryCompressed},
                           std::pair{"ascii.ply", Encoding::Ascii}, std::pair{"binary.ply", Encoding::Binary}})
  {
    pcl_ecs::io::writeCloud(path(name), pcl_ecs::io::formatFromPath(name), bunny, enc);
    variants.push_back(path(name));
  }
  for (const auto& v : variants)
  {
    const RunResult r = run(v + " " + path("v.pcd") + " -q");
    ASSERT_EQ(r.code, 0) << v << ": " << r.err;
    const auto got = load(path("v.pcd"));
    EXPECT_EQ(got.width, ref.width) << v;
    EXPECT_EQ(got.data, ref.data) << v;
  }
}

TEST_F(Cli, ContradictoryFlagsAreUsageErrors)
{
  const std::string in = kShared + "/bunny.pcd";
  const std::string out = " " + path("out.pcd");
  const std::set<std::string> none;
  expectRefused(in + out + " --terr 1e-3 --target-size 500", 2, none, "exclude each other");
  expectRefused(in + out + " --target-ratio 0.1 --terr 1e-3", 2, none, "exclude each other");
  expectRefused(in + out + " --target-cap 2", 2, none, "only with --target-size");
  expectRefused(in + out + " --target-gap 0.5", 2, none, "only with --target-size");
  expectRefused(in + out + " --no-adapt --adapt-factor 3", 2, none, "exclude each other");
  expectRefused(in + out + " --quiet=yes", 2, none, "takes no value");
  expectRefused(in + out + " --max-deviation 0.1% --target-ratio 0.1", 2, none, "exclude each other");
  expectRefused(in + out + " --max-deviation 1e-4 --target-size 500", 2, none, "exclude each other");
  expectRefused(in + out + " --max-deviation 150%", 2, none, "max_deviation");
  expectRefused(in + out + " --max-deviation x%", 2, none, "not a number or a percentage");
  expectRefused(in + out + " --terr-abs 0.001 --terr 1e-3", 2, none, "exclude each other");
  expectRefused(in + out + " --terr-abs 0.001 --target-ratio 0.1", 2, none, "exclude each other");
  expectRefused(in + out + " --feature-spacing 1 --target-ratio 0.1", 2, none, "thins the feature points itself");
  expectRefused(in + out + " --feature-spacing -1", 2, none, "feature_spacing");
  expectRefused(in + out + " --feature-spacing 1 --stream", 4, none, "--feature-spacing is not supported");
}

TEST_F(Cli, MaxDeviationHoldsOnEverySharedScan)
{
  // Every shared scan with --max-deviation 0.5% of L: the reported maximum is within the bound,
  // and so is every tenth input point measured independently on the files as PCL reads them
  // (a k-d tree over the output, the plane of the 8 nearest by Eigen's iterative solver), up to
  // the rounding of the coordinates the files hold.
  std::size_t checked = 0;
  for (const auto& e : fs::directory_iterator(kShared))
  {
    if (e.path().extension() != ".pcd")
      continue;
    const std::string name = e.path().filename().string();
    const RunResult r = run(e.path().string() + " " + path("o.pcd") + " --max-deviation 0.5% --stats " +
                            path("s.json"));
    ASSERT_EQ(r.code, 0) << name << ": " << r.err;
    EXPECT_NE(r.out.find("deviation max"), std::string::npos) << r.out;
    const auto j = nlohmann::json::parse(slurp(path("s.json")));
    const double L = j["geometry"]["bbox_diagonal"].get<double>();
    const double bound = j["deviation"]["bound"].get<double>();
    EXPECT_NEAR(bound, 0.005 * L, 1e-9 * L) << name;
    EXPECT_LE(j["deviation"]["max"].get<double>(), bound) << name;
    EXPECT_EQ(j["parameters"]["max-deviation"].get<std::string>(), "0.5%");

    pcl::PointCloud<pcl::PointXYZ> input, output;
    pcl::fromPCLPointCloud2(load(e.path().string()), input);
    pcl::fromPCLPointCloud2(load(path("o.pcd")), output);
    double extent = 0.0;
    for (const auto& q : input)
      if (std::isfinite(q.x))
        extent = std::max(extent, static_cast<double>(q.getVector3fMap().cwiseAbs().maxCoeff()));
    const double rounding = 16.0 * extent * std::numeric_limits<float>::epsilon();
    pcl::KdTreeFLANN<pcl::PointXYZ> tree;
    tree.setInputCloud(output.makeShared());
    std::vector<int> idx;
    std::vector<float> d2;
    double worst = 0.0;
    for (std::size_t i = 0; i < input.size(); i += 10)
    {
      const auto& q = input[i];
      if (!std::isfinite(q.x) || !std::isfinite(q.y) || !std::isfinite(q.z))
        continue;
      tree.nearestKSearch(q, 8, idx, d2);
      const Eigen::Vector3d p = q.getVector3fMap().cast<double>();
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (const int k : idx)
        c += output[static_cast<std::size_t>(k)].getVector3fMap().cast<double>();
      c /= static_cast<double>(idx.size());
      Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
      for (const int k : idx)
      {
        const Eigen::Vector3d v = output[static_cast<std::size_t>(k)].getVector3fMap().cast<double>() - c;
        cov += v * v.transpose();
      }
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
      const double plane = std::abs((p - c).dot(es.eigenvectors().col(0)));
      worst = std::max(worst, std::min(plane, std::sqrt(static_cast<double>(d2[0]))));
    }
    EXPECT_LE(worst, bound + rounding) << name;
    ++checked;
  }
  EXPECT_GE(checked, 20u);
}

TEST_F(Cli, FlagEqualsValueIsTheSameAsTwoWords)
{
  const std::string in = kShared + "/bunny.pcd";
  RunResult a = run(in + " " + path("a.pcd") + " --terr 2e-3 --alpha 5 --stats " + path("a.json") + " -q");
  RunResult b = run(in + " " + path("b.pcd") + " --terr=2e-3 --alpha=5 --stats=" + path("b.json") + " -q");
  ASSERT_EQ(a.code, 0) << a.err;
  ASSERT_EQ(b.code, 0) << b.err;
  EXPECT_EQ(slurp(path("a.pcd")), slurp(path("b.pcd")));
  EXPECT_TRUE(fs::exists(path("b.json")));
}

TEST_F(Cli, UnreachableTargetIsReported)
{
  const std::string in = kShared + "/bunny.pcd";
  const RunResult r = run(in + " " + path("a.pcd") + " --target-size 2 --stats " + path("a.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("out of reach"), std::string::npos) << r.err;
  const auto j = nlohmann::json::parse(slurp(path("a.json")));
  EXPECT_FALSE(j["target_reached"].get<bool>());
  EXPECT_EQ(j["target"]["size"].get<std::size_t>(), 2u);
  EXPECT_EQ(j["target"]["closest_size"].get<std::size_t>(), load(path("a.pcd")).width);
  // One point, fewer than the feature points alone: the search still makes as few balls as it can,
  // so the closest size is no larger than for two.
  const RunResult one = run(in + " " + path("c.pcd") + " --target-size 1 --stats " + path("c.json"));
  ASSERT_EQ(one.code, 0) << one.err;
  EXPECT_NE(one.err.find("out of reach"), std::string::npos) << one.err;
  EXPECT_LE(nlohmann::json::parse(slurp(path("c.json")))["target"]["closest_size"].get<std::size_t>(),
            j["target"]["closest_size"].get<std::size_t>());
  // A reachable target says nothing of the kind.
  const RunResult ok = run(in + " " + path("b.pcd") + " --target-ratio 0.05 --stats " + path("b.json"));
  ASSERT_EQ(ok.code, 0) << ok.err;
  EXPECT_EQ(ok.err.find("out of reach"), std::string::npos) << ok.err;
  EXPECT_TRUE(nlohmann::json::parse(slurp(path("b.json")))["target_reached"].get<bool>());
}

TEST_F(Cli, OutputsThatAreTheSameFileAreUsageErrors)
{
  const std::string in = kShared + "/bunny.pcd";
  const std::set<std::string> none;
  expectRefused(in + " " + path("a.pcd") + " --features " + path("a.pcd"), 2, none, "also OUTPUT");
  expectRefused(in + " " + path("a.ply") + " --mesh " + path("a.ply"), 2, none, "also OUTPUT");
  expectRefused(in + " " + path("a.pcd") + " --features " + path("f.ply") + " --mesh " + path("./f.ply"), 2, none,
                "also --features");
}

// A full filesystem: the write fails with exit 4 and one line, the old output stays as it was, and
// no temporary file is left, for every encoding (PCL's writer, used before, reported success with
// a truncated ascii file and died of SIGBUS writing binary through mmap).
TEST_F(Cli, FullDiskKeepsTheOldOutputAndLeavesNothing)
{
  const std::string mnt = path("small");
  fs::create_directories(mnt);
  if (pcl_ecs_test::runCommand("mount -t tmpfs -o size=32k tmpfs " + mnt, dir_).code != 0)
    GTEST_SKIP() << "cannot mount a small tmpfs here (CI runs as root and can)";
  struct Unmount
  {
    std::string dir, mnt;
    ~Unmount() { pcl_ecs_test::runCommand("umount " + mnt, dir); }
  } unmount{dir_, mnt};
  const std::string old_content(20000, 'x');
  for (const char* flags : {"", " --ascii", " --compressed", " --ply"})
  {
    const bool ply = std::string(flags) == " --ply";
    const std::string target = mnt + (ply ? "/old.ply" : "/old.pcd");
    std::ofstream(target, std::ios::binary) << old_content;
    const RunResult r = run(kShared + "/bunny.pcd " + target + (ply ? "" : flags));
    EXPECT_EQ(r.code, 4) << flags << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(slurp(target), old_content) << flags;
    std::size_t entries = 0;
    for (const auto& e : fs::directory_iterator(mnt))
    {
      (void)e;
      ++entries;
    }
    EXPECT_EQ(entries, 1u) << flags << ": a temporary file was left";
    fs::remove(target);
  }
}

// SIGTERM or SIGINT while the output is being written: the old output intact, no temporary file.
TEST_F(Cli, SignalDuringTheWriteLeavesNoTemporary)
{
  // A large ascii output takes long enough to write that the signal lands during the write.
  const std::string in = kShared + "/terrain_csite1_utm.pcd";
  for (const char* sig : {"TERM", "INT"})
  {
    const std::string target = path("out.pcd");
    std::ofstream(target) << "old";
    // Started in the background; the signal is sent once the temporary file exists.
    std::ofstream(path("kill.sh")) << kTool << " " << in << " " << target << " --ascii --terr 1e-5 -q &\n"
                                   << "pid=$!\n"
                                   << "for i in $(seq 1 3000); do\n"
                                   << "  ls -a " << dir_ << " | grep -q '^[.]out[.]pcd[.]tmp' && break\n"
                                   << "  sleep 0.005\n"
                                   << "done\n"
                                   << "kill -" << sig << " $pid\n"
                                   << "wait $pid\n"
                                   << "echo status $?\n";
    const RunResult r = pcl_ecs_test::runCommand("sh " + path("kill.sh"), dir_);
    EXPECT_NE(r.out.find("status"), std::string::npos) << r.out << r.err;
    const bool finished = r.out.find("status 0") != std::string::npos;
    std::printf("SIGTERM/SIGINT test (%s): %s", sig, r.out.c_str());
    if (!finished)
      EXPECT_EQ(slurp(target), "old") << sig;
    fs::remove(path("kill.sh"));
    for (const auto& e : fs::directory_iterator(dir_))
      EXPECT_EQ(e.path().filename().string().find(".out.pcd.tmp"), std::string::npos)
          << sig << ": left behind: " << e.path();
  }
}

// Every PCD field type is read in memory as --stream reads it: float64 coordinates (all three, or
// z alone), integer and 16-bit fields. The run is the float32 run's, and the fields keep their types.
TEST_F(Cli, TypedFieldsAreReadInMemory)
{
  const pcl::PCLPointCloud2 bunny = load(kShared + "/bunny.pcd");
  pcl::PointCloud<pcl::PointXYZ> pts;
  pcl_ecs::io::fromCloud(bunny, pts);
  const std::size_t n = pts.size();
  ASSERT_EQ(run(kShared + "/bunny.pcd " + path("ref.pcd") + " -q").code, 0);
  const std::size_t ref_points = load(path("ref.pcd")).width;
  struct Layout
  {
    const char* name;
    std::uint8_t xy, z;  // coordinate types
  };
  for (const Layout& l : {Layout{"f8.pcd", pcl::PCLPointField::FLOAT64, pcl::PCLPointField::FLOAT64},
                          Layout{"z8.pcd", pcl::PCLPointField::FLOAT32, pcl::PCLPointField::FLOAT64}})
  {
    pcl::PCLPointCloud2 c;
    c.height = 1;
    c.width = static_cast<std::uint32_t>(n);
    const std::pair<const char*, std::uint8_t> fields[] = {{"x", l.xy}, {"y", l.xy}, {"z", l.z},
                                                           {"intensity", pcl::PCLPointField::UINT16},
                                                           {"ring", pcl::PCLPointField::INT8}};
    for (const auto& [name, type] : fields)
    {
      pcl::PCLPointField f;
      f.name = name;
      f.datatype = type;
      f.count = 1;
      f.offset = c.point_step;
      c.fields.push_back(f);
      c.point_step += static_cast<std::uint32_t>(pcl::getFieldSize(type));
    }
    c.data.resize(n * c.point_step);
    for (std::size_t i = 0; i < n; ++i)
    {
      std::uint8_t* rec = c.data.data() + i * c.point_step;
      const double v[5] = {pts[i].x, pts[i].y, pts[i].z, static_cast<double>(i % 65536), static_cast<double>(i % 200) - 100};
      for (int k = 0; k < 5; ++k)
      {
        const auto& f = c.fields[static_cast<std::size_t>(k)];
        if (f.datatype == pcl::PCLPointField::FLOAT64) { std::memcpy(rec + f.offset, &v[k], 8); }
        else if (f.datatype == pcl::PCLPointField::FLOAT32) { const float x = static_cast<float>(v[k]); std::memcpy(rec + f.offset, &x, 4); }
        else if (f.datatype == pcl::PCLPointField::UINT16) { const auto x = static_cast<std::uint16_t>(v[k]); std::memcpy(rec + f.offset, &x, 2); }
        else { const auto x = static_cast<std::int8_t>(v[k]); std::memcpy(rec + f.offset, &x, 1); }
      }
    }
    pcl_ecs::io::writeCloud(path(l.name), pcl_ecs::io::Format::Pcd, c, pcl_ecs::io::Encoding::Binary);
    const RunResult r = run(path(l.name) + " " + path("out.pcd") + " -q");
    ASSERT_EQ(r.code, 0) << l.name << ": " << r.err;
    const pcl::PCLPointCloud2 out = load(path("out.pcd"));
    EXPECT_EQ(out.width, ref_points) << l.name;
    ASSERT_EQ(out.fields.size(), 5u);
    for (std::size_t k = 0; k < 5; ++k)
    {
      EXPECT_EQ(out.fields[k].name, fields[k].first);
      EXPECT_EQ(out.fields[k].datatype, fields[k].second) << l.name << " " << fields[k].first;
    }
    // Every output point's intensity and ring name one input point, as a pair.
    for (std::size_t i = 0; i < out.width; ++i)
    {
      std::uint16_t in;
      std::int8_t ring;
      std::memcpy(&in, out.data.data() + i * out.point_step + out.fields[3].offset, 2);
      std::memcpy(&ring, out.data.data() + i * out.point_step + out.fields[4].offset, 1);
      bool found = false;
      for (std::size_t j = in; j < n && !found; j += 65536)
        found = static_cast<int>(j % 200) - 100 == ring;
      EXPECT_TRUE(found) << l.name << ": point " << i;
    }
  }
}

// A real scan in which every point is stored twice: simplified as the scan without the copies, in
// T_err mode, with a target ratio (of the distinct points) and streamed, and the summary says so.
TEST_F(Cli, RoomScanWithEveryPointTwiceIsSimplifiedAsTheScanOnce)
{
  const std::string in = kShared + "/room_scan2.pcd";
  const pcl::PCLPointCloud2 all = load(in);
  // The scan once: first occurrences of each position, in file order.
  std::set<std::array<float, 3>> seen;
  pcl::PCLPointCloud2 once = all;
  once.data.clear();
  const int fx = pcl_ecs::io::fieldIndex(all.fields, "x");
  ASSERT_GE(fx, 0);
  for (std::size_t i = 0; i < static_cast<std::size_t>(all.width) * all.height; ++i)
  {
    const std::uint8_t* rec = all.data.data() + i * all.point_step;
    std::array<float, 3> p;
    std::memcpy(p.data(), rec + all.fields[static_cast<std::size_t>(fx)].offset, 12);
    if (std::isfinite(p[0]) && seen.insert(p).second)
      once.data.insert(once.data.end(), rec, rec + all.point_step);
  }
  once.width = static_cast<std::uint32_t>(once.data.size() / once.point_step);
  once.height = 1;
  once.row_step = once.width * once.point_step;
  ASSERT_LT(once.width * 10u, all.width * 6u) << "the scan is expected to hold most points twice";
  pcl_ecs::io::writeCloud(path("once.pcd"), pcl_ecs::io::Format::Pcd, once, pcl_ecs::io::Encoding::Binary);
  for (const std::string mode : {"", " --target-ratio 0.1", " --stream"})
  {
    const RunResult r2 = run(in + " " + path("twice_out.pcd") + mode);
    const RunResult r1 = run(path("once.pcd") + " " + path("once_out.pcd") + mode);
    ASSERT_EQ(r2.code, 0) << r2.err;
    ASSERT_EQ(r1.code, 0) << r1.err;
    EXPECT_NE(r2.out.find("coincident points merged"), std::string::npos) << r2.out;
    const double n2 = load(path("twice_out.pcd")).width, n1 = load(path("once_out.pcd")).width;
    EXPECT_NEAR(n2, n1, 0.01 * n1) << mode;
    EXPECT_LT(n2, 0.2 * once.width) << mode << ": the doubled scan must be simplified, not returned as it is";
  }
}

// Field names travel exactly: rgb + label stays rgb + label (it became rgba through PointXYZRGBL).
TEST_F(Cli, FieldNamesAreKeptExactly)
{
  pcl::PCLPointCloud2 bunny = load(kShared + "/bunny.pcd");
  pcl::PCLPointCloud2 c;
  c.height = 1;
  c.width = bunny.width * bunny.height;
  for (const char* name : {"x", "y", "z", "rgb", "label"})
  {
    pcl::PCLPointField f;
    f.name = name;
    f.datatype = std::string(name) == "label" ? pcl::PCLPointField::UINT32 : pcl::PCLPointField::FLOAT32;
    f.count = 1;
    f.offset = c.point_step;
    c.fields.push_back(f);
    c.point_step += 4;
  }
  pcl::PointCloud<pcl::PointXYZ> pts;
  pcl_ecs::io::fromCloud(bunny, pts);
  c.data.resize(static_cast<std::size_t>(c.width) * c.point_step);
  for (std::size_t i = 0; i < pts.size(); ++i)
  {
    std::uint8_t* rec = c.data.data() + i * c.point_step;
    std::memcpy(rec, &pts[i].x, 12);
    const std::uint32_t rgb = 0xFF000000u | static_cast<std::uint32_t>(i * 2654435761u >> 8), label = static_cast<std::uint32_t>(i);
    std::memcpy(rec + 12, &rgb, 4);
    std::memcpy(rec + 16, &label, 4);
  }
  pcl_ecs::io::writeCloud(path("rgbl.pcd"), pcl_ecs::io::Format::Pcd, c, pcl_ecs::io::Encoding::Binary);
  for (const char* out : {"o.pcd", "o.ply"})
  {
    ASSERT_EQ(run(path("rgbl.pcd") + " " + path(out) + " -q").code, 0) << out;
    const pcl::PCLPointCloud2 back = load(path(out));
    std::set<std::string> names;
    for (const auto& f : back.fields)
      names.insert(f.name);
    EXPECT_EQ(names, (std::set<std::string>{"x", "y", "z", "rgb", "label"})) << out;
  }
  EXPECT_NE(slurp(path("o.pcd")).find("FIELDS x y z rgb label\n"), std::string::npos);
}

// A header that claims more points than this machine could hold in memory (a 2 GB sparse file,
// a small compressed file claiming 1 GiB of points) is refused before anything is allocated.
TEST_F(Cli, CloudsLargerThanMemoryAreRefusedBeforeReading)
{
  const std::uint64_t points = 4000000000ull;  // 48 GB of xyz: more than any CI machine has
  const std::string header = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " +
                             std::to_string(points) + "\nHEIGHT 1\nPOINTS " + std::to_string(points) + "\nDATA ";
  std::ofstream(path("sparse.pcd"), std::ios::binary) << header << "binary\n";
  fs::resize_file(path("sparse.pcd"), header.size() + 7 + points * 12);  // sparse: no disk used
  {
    std::ofstream bomb(path("bomb.pcd"), std::ios::binary);
    bomb << header << "binary_compressed\n";
    const std::uint32_t sizes[2] = {16, 0xFFFFFFF0u};  // 16 bytes that would unpack to 4 GiB
    bomb.write(reinterpret_cast<const char*>(sizes), 8);
    bomb << std::string(16, '\0');
  }
  for (const char* name : {"sparse.pcd", "bomb.pcd"})
  {
    const RunResult r = run(path(name) + " " + path("out.pcd"));
    EXPECT_EQ(r.code, 3) << name << ": " << r.err;
    if (std::string(name) == "sparse.pcd")
      EXPECT_NE(r.err.find("use --stream"), std::string::npos) << r.err;
#ifndef PCL_ECS_SANITIZED  // the sanitizers' shadow memory is not the tool's
    EXPECT_LT(r.peak_rss_kib, 200L * 1024) << name << ": peak RSS " << r.peak_rss_kib / 1024 << " MiB";
#endif
    EXPECT_FALSE(fs::exists(path("out.pcd")));
  }
}

// A header line of 20 MB (an unknown keyword) and a file of terminal escape sequences: refused in
// one short printable line, the long line never read whole, nothing written.
TEST_F(Cli, HostileHeadersAreRefusedInOneShortLine)
{
  std::ofstream(path("long.pcd"), std::ios::binary) << "VERSION 0.7\nFIELDS" << std::string(20u << 20, 'x') << "\n";
  std::ofstream(path("escape.pcd"), std::ios::binary) << "\x1b[2J\x1b]0;owned\x07\nVERSION 0.7\n";
  for (const char* name : {"long.pcd", "escape.pcd"})
  {
    const RunResult r = run(path(name) + " " + path("out.pcd"));
    EXPECT_EQ(r.code, 3) << name << ": " << r.err.substr(0, 500);
    EXPECT_LE(r.err.size(), 600u) << name;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << name;
    EXPECT_EQ(r.err.find('\x1b'), std::string::npos) << name;
    EXPECT_FALSE(fs::exists(path("out.pcd")));
  }
#ifndef PCL_ECS_SANITIZED
  const RunResult r = run(path("long.pcd") + " " + path("out.pcd"));
  EXPECT_LT(r.peak_rss_kib, 45L * 1024) << "the 20 MB line was read whole: " << r.peak_rss_kib / 1024 << " MiB";
#endif
}

// Input quoted in a message is at most 80 characters: an unknown 10 KB keyword, a 5 KB field name
// with a bad ascii value, a 10 KB token in the data, in memory and with --stream.
TEST_F(Cli, MessagesQuoteAtMostEightyCharactersOfInput)
{
  const std::string k(10000, 'K'), name(5000, 'N'), token(10000, 'T');
  std::ofstream(path("keyword.pcd")) << "VERSION 0.7\n" << k << " 1\n";
  std::ofstream(path("field.pcd")) << "VERSION 0.7\nFIELDS x y z " << name << "\nSIZE 4 4 4 4\nTYPE F F F F\n"
                                   << "COUNT 1 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3 abc\n";
  std::ofstream(path("token.pcd")) << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                                   << "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 " << token << "\n";
  auto longest_run = [](const std::string& text, char c) {
    std::size_t best = 0, run = 0;
    for (char t : text)
      best = std::max(best, run = t == c ? run + 1 : 0);
    return best;
  };
  for (const char* mode : {"", " --stream"})
    for (const auto& [file, c] : {std::pair<const char*, char>{"keyword.pcd", 'K'}, {"field.pcd", 'N'}, {"token.pcd", 'T'}})
    {
      const RunResult r = run(path(file) + " " + path("out.pcd") + mode);
      EXPECT_EQ(r.code, 3) << file << mode << ": " << r.err.substr(0, 300);
      EXPECT_GE(longest_run(r.err, c), 10u) << file << mode << ": the input is not quoted at all: " << r.err;
      EXPECT_LE(longest_run(r.err, c), 80u) << file << mode << ": " << r.err.substr(0, 300);
      EXPECT_FALSE(fs::exists(path("out.pcd")));
    }
}

namespace
{
/// Feeds `bytes` into the FIFO at `path` once a reader has opened it (gives up after 20 s, or when
/// the reader goes away).
std::thread feedFifo(const std::string& path, std::string bytes)
{
  return std::thread([path, bytes = std::move(bytes)] {
    int fd = -1;
    for (int i = 0; i < 2000 && fd < 0; ++i)
    {
      fd = ::open(path.c_str(), O_WRONLY | O_NONBLOCK);  // ENXIO until a reader has it open
      if (fd < 0)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    if (fd < 0)
      return;
    ::fcntl(fd, F_SETFL, 0);  // blocking writes from here on
    std::size_t put = 0;
    while (put < bytes.size())
    {
      const ssize_t w = ::write(fd, bytes.data() + put, bytes.size() - put);
      if (w <= 0)
        break;  // the reader went away
      put += static_cast<std::size_t>(w);
    }
    ::close(fd);
  });
}
}  // namespace

// A FIFO (or any pipe given by name) is read once, as it comes: in memory (PCD and PLY) and with
// --stream (binary and ascii PCD) the result is the regular file's; a binary_compressed PCD cannot
// be streamed from a pipe (its fields are stored one after another) and says so. Before, the
// in-memory reader consumed the header to size the cloud and read garbage, and --stream read the
// data twice ("truncated: the data ends in point 0").
TEST_F(Cli, FifoInputsAreReadOnce)
{
  ::signal(SIGPIPE, SIG_IGN);
  const std::string bunny = kShared + "/bunny.pcd";
  pcl::PCLPointCloud2 blob = load(bunny);
  pcl_ecs::io::writeCloud(path("ascii.pcd"), pcl_ecs::io::Format::Pcd, blob, pcl_ecs::io::Encoding::Ascii);
  pcl_ecs::io::writeCloud(path("packed.pcd"), pcl_ecs::io::Format::Pcd, blob, pcl_ecs::io::Encoding::BinaryCompressed);
  pcl_ecs::io::writeCloud(path("bunny.ply"), pcl_ecs::io::Format::Ply, blob, pcl_ecs::io::Encoding::Binary);
  struct Case
  {
    std::string file, fifo, mode;
  };
  for (const Case& c : {Case{bunny, "in.pcd", ""}, Case{path("bunny.ply"), "in.ply", ""},
                        Case{bunny, "in.pcd", " --stream"}, Case{path("ascii.pcd"), "in.pcd", " --stream"},
                        Case{path("packed.pcd"), "in.pcd", ""}})
  {
    SCOPED_TRACE(c.file + c.mode);
    fs::remove(path(c.fifo));
    ASSERT_EQ(::mkfifo(path(c.fifo).c_str(), 0600), 0);
    const RunResult ref = run(c.file + " " + path("ref.pcd") + c.mode);
    ASSERT_EQ(ref.code, 0) << ref.err;
    std::thread feeder = feedFifo(path(c.fifo), slurp(c.file));
    const RunResult r = run(path(c.fifo) + " " + path("out.pcd") + c.mode);
    feeder.join();
    ASSERT_EQ(r.code, 0) << r.err;
    const pcl::PCLPointCloud2 a = load(path("ref.pcd")), b = load(path("out.pcd"));
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.data, b.data);
  }
  fs::remove(path("in.pcd"));
  ASSERT_EQ(::mkfifo(path("in.pcd").c_str(), 0600), 0);
  std::thread feeder = feedFifo(path("in.pcd"), slurp(path("packed.pcd")));
  const RunResult r = run(path("in.pcd") + " " + path("streamed.pcd") + " --stream");
  feeder.join();
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("cannot be streamed from a pipe"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("streamed.pcd")));
}

// A 2 GB sparse PLY whose header declares 179M vertices it does not hold is refused from its
// header, unread (it was read whole first: 4.2 GB and 15 s before the same message).
TEST_F(Cli, APlyPromisingMoreThanItHoldsIsRefusedUnread)
{
  std::ofstream(path("huge.ply"), std::ios::binary)
      << "ply\nformat binary_little_endian 1.0\nelement vertex 179000000\nproperty float x\nproperty float y\n"
         "property float z\nend_header\n";
  fs::resize_file(path("huge.ply"), 2000000000ull);
  const RunResult r = run(path("huge.ply") + " " + path("out.pcd"));
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("truncated: 179000000 vertices"), std::string::npos) << r.err;
#ifndef PCL_ECS_SANITIZED
  EXPECT_LT(r.peak_rss_kib, 100L * 1024) << "read whole: " << r.peak_rss_kib / 1024 << " MiB";
#endif
  EXPECT_FALSE(fs::exists(path("out.pcd")));
}
