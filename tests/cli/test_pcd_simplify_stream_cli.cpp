// pcd_simplify --stream and pcd_make_scan as users run them: a generated multi-scan input, a run
// killed midway and started again (same bytes as an uninterrupted run), peak memory under the
// limit, progress on stderr, and refusals with their exit codes and nothing left behind.
#include "cli_fixture.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/io/cloud_io.h>
#include <pcl_ecs/io/las_io.h>
#include <pcl_ecs/io/pcd_stream.h>

#include <cmath>
#include <cstring>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <pcl/common/common.h>
#include <pcl/conversions.h>
#include <pcl/point_types.h>

namespace fs = std::filesystem;
using pcl_ecs_test::RunResult;
using pcl_ecs_test::slurp;

namespace
{
const std::string kSimplify = PCD_SIMPLIFY_PATH;
const std::string kMakeScan = PCD_MAKE_SCAN_PATH;
const std::string kShared = PCL_ECS_SHARED_DATA_DIR;
#ifdef PCL_ECS_SANITIZED
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif

class StreamCli : public pcl_ecs_test::TempDirTest
{
protected:
  std::string makeScan(const std::string& name, std::size_t points, const std::string& extra = "")
  {
    const RunResult r = runTool(kMakeScan, kShared + "/bunny_mesh.ply " + path(name) + " --points " +
                                               std::to_string(points) + " --quiet " + extra);
    EXPECT_EQ(r.code, 0) << r.err;
    return path(name);
  }
  std::set<std::string> entries() const
  {
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_))
      names.insert(e.path().filename().string());
    return names;
  }
};
}  // namespace

TEST_F(StreamCli, GeneratorWritesTheAskedSizeWithVaryingDensity)
{
  const std::string scan = makeScan("scan.pcd", 100000, "--scans 4 --seed 3");
  pcl_ecs::io::PcdStreamReader r(scan);
  EXPECT_EQ(r.header().points, 100000u);
  ASSERT_EQ(r.header().fieldIndex("scan"), 4);
  std::vector<std::uint8_t> rec;
  std::size_t per_scan[4] = {0, 0, 0, 0};
  while (r.read(10000, rec) > 0)
    for (std::size_t i = 0; i < rec.size() / r.header().point_step; ++i)
      ++per_scan[rec[i * r.header().point_step + 16]];
  for (const std::size_t c : per_scan)
    EXPECT_EQ(c, 25000u);
  // Same seed, same bytes; another seed, other bytes.
  EXPECT_EQ(slurp(makeScan("again.pcd", 100000, "--scans 4 --seed 3")), slurp(scan));
  EXPECT_NE(slurp(makeScan("other.pcd", 100000, "--scans 4 --seed 4")), slurp(scan));
  const RunResult bad = runTool(kMakeScan, kShared + "/bunny_mesh.ply " + path("x.pcd") + " --points 0");
  EXPECT_EQ(bad.code, 2);
  const RunResult missing = runTool(kMakeScan, path("nope.ply") + " " + path("x.pcd") + " --points 10");
  EXPECT_EQ(missing.code, 3);
  EXPECT_FALSE(fs::exists(path("x.pcd")));
}

TEST_F(StreamCli, KilledRunResumesToTheSameBytes)
{
  const std::size_t points = kSanitized ? 40000 : 300000;
  const std::string scan = makeScan("scan.pcd", points);
  const std::string common = scan + " %s --stream --tile-points " + std::to_string(points / 4) + " --scratch " + path("scratch") + " --stats " +
                             path("%s.json");
  auto args = [&](const std::string& out) {
    std::string a = common;
    a.replace(a.find("%s"), 2, path(out));
    a.replace(a.find("%s"), 2, out);
    return a;
  };
  const RunResult whole = runTool(kSimplify, args("whole.pcd") + " --quiet");
  ASSERT_EQ(whole.code, 0) << whole.err;
  ASSERT_FALSE(fs::exists(path("scratch")));
  const auto j = nlohmann::json::parse(slurp(path("whole.pcd.json")));
  const std::size_t tiles = j["tiles"]["list"].size();
  ASSERT_GE(tiles, 3u);
  // Killed in phase B (after every tile of phase A and one of B), in phase C, then in phase D (the
  // gap bound; every tile's points and values are gone from the scratch by then, as nothing after
  // its cover reads them).
  for (const std::size_t kill_at : {tiles + 1, 2 * tiles + 1, 3 * tiles + 1})
  {
    SCOPED_TRACE("killed after step " + std::to_string(kill_at));
    const RunResult killed = runTool(kSimplify, args("again.pcd") + " --quiet --debug-kill-after " + std::to_string(kill_at));
    EXPECT_EQ(killed.signal, SIGKILL) << killed.err;
    EXPECT_FALSE(fs::exists(path("again.pcd")));
    EXPECT_TRUE(fs::exists(path("scratch")));
    const RunResult resumed = runTool(kSimplify, args("again.pcd"));
    ASSERT_EQ(resumed.code, 0) << resumed.err;
    EXPECT_NE(resumed.err.find("resuming"), std::string::npos) << resumed.err;
    EXPECT_EQ(slurp(path("again.pcd")), slurp(path("whole.pcd")));
    EXPECT_TRUE(nlohmann::json::parse(slurp(path("again.pcd.json")))["resumed"].get<bool>());
    fs::remove(path("again.pcd"));
  }
  EXPECT_FALSE(fs::exists(path("scratch")));
  // A tile's saved point order (phase A writes it, later phases read it) that no longer matches
  // the tile's points is refused, with nothing written.
  const RunResult killed = runTool(kSimplify, args("again.pcd") + " --quiet --debug-kill-after " + std::to_string(tiles + 1));
  ASSERT_EQ(killed.signal, SIGKILL) << killed.err;
  const fs::path order = fs::path(path("scratch")) / "a" / "0.order";
  ASSERT_TRUE(fs::exists(order));
  fs::resize_file(order, fs::file_size(order) - 4);
  const RunResult damaged = runTool(kSimplify, args("again.pcd") + " --quiet");
  EXPECT_NE(damaged.code, 0);
  EXPECT_NE(damaged.err.find("damaged"), std::string::npos) << damaged.err;
  EXPECT_FALSE(fs::exists(path("again.pcd")));
  // So are phase A's neighbour lists cut short (read by phase B, for the tiles it has not done).
  fs::remove_all(path("scratch"));
  const RunResult killed_again = runTool(kSimplify, args("again.pcd") + " --quiet --debug-kill-after " + std::to_string(tiles + 1));
  ASSERT_EQ(killed_again.signal, SIGKILL) << killed_again.err;
  std::size_t cut = 0;
  for (std::size_t t = 0; t < tiles; ++t)
  {
    const fs::path root(path("scratch"));
    const fs::path front = root / "a" / (std::to_string(t) + ".front");
    if (fs::exists(root / "b" / (std::to_string(t) + ".sum")) || !fs::exists(front))
      continue;
    fs::resize_file(front, fs::file_size(front) - 4);
    ++cut;
  }
  ASSERT_GT(cut, 0u);
  const RunResult cut_short = runTool(kSimplify, args("again.pcd") + " --quiet");
  EXPECT_NE(cut_short.code, 0);
  EXPECT_NE(cut_short.err.find("neighbour lists"), std::string::npos) << cut_short.err;
  EXPECT_FALSE(fs::exists(path("again.pcd")));
}

TEST_F(StreamCli, PeakMemoryStaysUnderTheLimit)
{
  if (kSanitized)
    GTEST_SKIP() << "sanitizers change memory use; the Release run checks it";
  const std::string scan = makeScan("big.pcd", 3000000, "--scans 8");
  const RunResult r = runTool(kSimplify, scan + " " + path("out.pcd") + " --stream --memory-limit 256M --stats " +
                                             path("s.json"));
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_LT(r.peak_rss_kib, 256L * 1024) << "peak RSS " << r.peak_rss_kib / 1024 << " MiB";
  const auto j = nlohmann::json::parse(slurp(path("s.json")));
  EXPECT_GE(j["tiles"]["list"].size(), 4u);
  EXPECT_EQ(j["counts"]["finite_points"].get<std::size_t>(), 3000000u);
  // Progress lines on stderr: tiles done, rate, ETA.
  EXPECT_NE(r.err.find("M points/s, ETA"), std::string::npos) << r.err;
  // The output keeps the input's fields.
  pcl_ecs::io::PcdStreamReader out(path("out.pcd"));
  EXPECT_GE(out.header().fieldIndex("intensity"), 0);
  EXPECT_GE(out.header().fieldIndex("scan"), 0);
}

TEST_F(StreamCli, LazInputIsReadInChunksAndGivesWhatItsPointsGiveAsPcd)
{
  // A UTM-sized LAZ scan; the same records (as pcl_ecs reads them in memory) as a binary PCD.
  const std::string laz = makeScan("scan.laz", kSanitized ? 200000 : 2000000,
                                   "--scans 4 --scale 100 --offset 512000 4100000 200");
  pcl::PCLPointCloud2 cloud;
  pcl_ecs::io::LasInfo info;
  ASSERT_TRUE(pcl_ecs::io::readCloud(laz, cloud, &info));
  EXPECT_TRUE(info.compressed);
  pcl_ecs::io::writeCloud(path("scan.pcd"), pcl_ecs::io::Format::Pcd, cloud, pcl_ecs::io::Encoding::Binary);
  const std::string flags = " --stream --memory-limit 128M --quiet";
  const RunResult from_laz = runTool(kSimplify, laz + " " + path("a.pcd") + flags);
  ASSERT_EQ(from_laz.code, 0) << from_laz.err;
  if (!kSanitized)
    EXPECT_LT(from_laz.peak_rss_kib, 128L * 1024) << "peak RSS " << from_laz.peak_rss_kib / 1024 << " MiB";
  const RunResult from_pcd = runTool(kSimplify, path("scan.pcd") + " " + path("b.pcd") + flags);
  ASSERT_EQ(from_pcd.code, 0) << from_pcd.err;
  EXPECT_TRUE(slurp(path("a.pcd")) == slurp(path("b.pcd"))) << "the LAZ input gives what its points give";

  // LAZ out: the input's header, scale and offset; the same points to the scale.
  const RunResult to_laz = runTool(kSimplify, laz + " " + path("a.laz") + flags);
  ASSERT_EQ(to_laz.code, 0) << to_laz.err;
  pcl::PCLPointCloud2 out_laz, out_pcd;
  pcl_ecs::io::LasInfo out_info;
  ASSERT_TRUE(pcl_ecs::io::readCloud(path("a.laz"), out_laz, &out_info));
  pcl_ecs::io::readCloud(path("a.pcd"), out_pcd);
  EXPECT_EQ(out_info.scale, info.scale);
  EXPECT_EQ(out_info.offset, info.offset);
  ASSERT_EQ(out_laz.width, out_pcd.width);
  ASSERT_EQ(out_laz.point_step, out_pcd.point_step);
  for (std::size_t i = 0; i < out_laz.width; ++i)
  {
    const std::uint8_t* a = out_laz.data.data() + i * out_laz.point_step;
    const std::uint8_t* b = out_pcd.data.data() + i * out_pcd.point_step;
    for (int k = 0; k < 3; ++k)
    {
      double u, v;
      std::memcpy(&u, a + 8 * k, 8);
      std::memcpy(&v, b + 8 * k, 8);
      ASSERT_LE(std::abs(u - v), 0.5 * info.scale[k] * (1 + 1e-6) + 1e-9 * std::abs(v)) << "point " << i;
    }
    ASSERT_EQ(std::memcmp(a + 24, b + 24, out_laz.point_step - 24), 0) << "point " << i << "'s other dimensions";
  }
}

TEST_F(StreamCli, SeveralTilesAreSimplifiedAsOneCloud)
{
  // Three LAS tiles of one surface, side by side, each with its own offset; their records in one
  // binary PCD are the oracle.
  fs::create_directories(path("tiles"));
  std::vector<std::string> tiles;
  pcl::PCLPointCloud2 all;
  for (int i = 0; i < 3; ++i)
  {
    tiles.push_back(makeScan("tiles/t" + std::to_string(i) + ".las", 150000,
                             "--scale 100 --offset " + std::to_string(512000 + 15 * i) + " 4100000 200 --seed " +
                                 std::to_string(i + 1)));
    pcl::PCLPointCloud2 c;
    pcl_ecs::io::readCloud(tiles.back(), c);
    if (i == 0)
      all = c;
    else
    {
      ASSERT_EQ(c.point_step, all.point_step);
      all.data.insert(all.data.end(), c.data.begin(), c.data.end());
      all.width += c.width;
      all.row_step = all.width * all.point_step;
    }
  }
  pcl_ecs::io::writeCloud(path("all.pcd"), pcl_ecs::io::Format::Pcd, all, pcl_ecs::io::Encoding::Binary);
  const std::string flags = " --stream --memory-limit 256M --tile-points 100000 --quiet";
  const RunResult dir = runTool(kSimplify, path("tiles") + " " + path("dir.pcd") + flags);
  ASSERT_EQ(dir.code, 0) << dir.err;
  const RunResult listed = runTool(kSimplify, tiles[0] + " " + tiles[1] + " " + tiles[2] + " " + path("listed.pcd") + flags);
  ASSERT_EQ(listed.code, 0) << listed.err;
  const RunResult one = runTool(kSimplify, path("all.pcd") + " " + path("one.pcd") + flags);
  ASSERT_EQ(one.code, 0) << one.err;
  EXPECT_TRUE(slurp(path("dir.pcd")) == slurp(path("one.pcd"))) << "the tiles as one cloud";
  EXPECT_TRUE(slurp(path("listed.pcd")) == slurp(path("one.pcd")));
  // As LAS: a frame that holds every tile (the offsets differ), every point within half its scale.
  const RunResult las = runTool(kSimplify, path("tiles") + " " + path("out.las") + flags);
  ASSERT_EQ(las.code, 0) << las.err;
  pcl::PCLPointCloud2 a, b;
  pcl_ecs::io::LasInfo info;
  pcl_ecs::io::readCloud(path("out.las"), a, &info);
  pcl_ecs::io::readCloud(path("one.pcd"), b);
  ASSERT_EQ(a.width, b.width);
  for (std::size_t i = 0; i < a.width; ++i)
    for (int k = 0; k < 3; ++k)
    {
      double u, v;
      std::memcpy(&u, a.data.data() + i * a.point_step + 8 * k, 8);
      std::memcpy(&v, b.data.data() + i * b.point_step + 8 * k, 8);
      ASSERT_LE(std::abs(u - v), 0.5 * info.scale[k] * (1 + 1e-6) + 1e-9 * std::abs(v)) << i;
    }
  // A tile of another point format is refused, naming it; nothing is written.
  pcl::PCLPointCloud2 xyz;
  pcl_ecs::io::appendField(xyz, "x", pcl::PCLPointField::FLOAT64);
  pcl_ecs::io::appendField(xyz, "y", pcl::PCLPointField::FLOAT64);
  pcl_ecs::io::appendField(xyz, "z", pcl::PCLPointField::FLOAT64);
  pcl_ecs::io::appendField(xyz, "gps_time", pcl::PCLPointField::FLOAT64);
  xyz.width = 100;
  xyz.height = 1;
  xyz.data.assign(100 * xyz.point_step, 0);
  pcl_ecs::io::writeCloud(path("tiles/t3.las"), pcl_ecs::io::Format::Las, xyz, pcl_ecs::io::Encoding::Binary);
  const RunResult mixed = runTool(kSimplify, path("tiles") + " " + path("mixed.las") + flags);
  EXPECT_EQ(mixed.code, 3) << mixed.err;
  EXPECT_NE(mixed.err.find("t3.las"), std::string::npos) << mixed.err;
  EXPECT_FALSE(fs::exists(path("mixed.las")));
}

TEST_F(StreamCli, RefusalsLeaveNothingBehind)
{
  const std::string scan = makeScan("scan.pcd", 20000);
  const std::set<std::string> before = entries();
  struct Case
  {
    std::string args;
    int code;
    std::string message;
  };
  const std::vector<Case> cases = {
      {scan + " " + path("o.pcd") + " --stream --target-ratio 0.1", 2, "--terr"},
      {scan + " " + path("o.pcd") + " --stream --mesh " + path("m.ply"), 2, "in-memory"},
      {scan + " " + path("o.pcd") + " --stream --memory-limit lots", 2, "not a size"},
      {scan + " " + path("o.pcd") + " --stream --memory-limit 1M", 2, "at least 64M"},
      {scan + " " + path("o.pcd") + " --memory-limit 1G", 2, "need --stream"},
      // A sparse room whose halo alone fills a tile of 20,000 points: refused at the plan (it
      // split into 56,188 one-point tiles before), with the size that works.
      {kShared + "/room_scan2.pcd " + path("o.pcd") + " --stream --tile-points 20000", 2, "use at least --tile-points"},
      {scan + " " + path("o.ply") + " --stream", 2, ".pcd"},
      {path("missing.pcd") + " " + path("o.pcd") + " --stream", 3, "no such file"},
      {scan + " " + path("nodir/o.pcd") + " --stream", 4, "nodir"},
  };
  for (const Case& c : cases)
  {
    const RunResult r = runTool(kSimplify, c.args);
    EXPECT_EQ(r.code, c.code) << c.args << "\n" << r.err;
    EXPECT_NE(r.err.find(c.message), std::string::npos) << c.args << "\n" << r.err;
    EXPECT_EQ(entries(), before) << c.args;
  }
  // A truncated input: refused before any work, nothing written.
  fs::copy_file(scan, path("cut.pcd"));
  fs::resize_file(path("cut.pcd"), fs::file_size(scan) / 2);
  const RunResult r = runTool(kSimplify, path("cut.pcd") + " " + path("o.pcd") + " --stream");
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find("truncated"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(path("o.pcd")));
  EXPECT_FALSE(fs::exists(path("o.pcd.ecs-scratch")));
}

// --memory-limit is a promise for the whole process: on a 1M-point scan, 64M (the smallest limit
// the tool takes) is kept, or refused at once with the limit that works, which is then kept, run
// after run with the same bytes (the plan does not follow the process's start-up size, which
// varies by about a MiB between runs). Records so wide that not even two of the smallest tiles
// fit are refused the same way.
TEST_F(StreamCli, SmallMemoryLimitHoldsOrIsRefusedAtOnce)
{
  if (kSanitized)
    GTEST_SKIP() << "sanitizers change memory use; the Release run checks it";
  const std::string scan = makeScan("m1.pcd", 1000000, "--scans 4");
  auto suggested = [](const std::string& err) {
    const std::size_t at = err.find("use at least ");
    return at == std::string::npos ? -1L : std::stol(err.substr(at + 13));
  };
  RunResult r = runTool(kSimplify, scan + " " + path("out.pcd") + " --stream --memory-limit 64M --quiet");
  long limit_mib = 64;
  if (r.code == 2)
  {
    limit_mib = suggested(r.err);
    ASSERT_GT(limit_mib, 64) << r.err;
    EXPECT_FALSE(fs::exists(path("out.pcd")));
    r = runTool(kSimplify, scan + " " + path("out.pcd") + " --stream --quiet --memory-limit " +
                               std::to_string(limit_mib) + "M");
  }
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_LT(r.peak_rss_kib, limit_mib * 1024) << "peak RSS " << r.peak_rss_kib / 1024 << " MiB at --memory-limit "
                                              << limit_mib << "M";
  for (int again = 0; again < 2; ++again)
  {
    const RunResult r2 = runTool(kSimplify, scan + " " + path("again.pcd") + " --stream --quiet --memory-limit " +
                                                std::to_string(limit_mib) + "M");
    ASSERT_EQ(r2.code, 0) << r2.err;
    EXPECT_EQ(slurp(path("again.pcd")), slurp(path("out.pcd"))) << "the same limit gives the same bytes";
  }
  fs::remove(path("again.pcd"));

  // 1,000 float fields a point: two tiles of the smallest size need far more than 64M.
  const std::size_t n = 3000, fields = 1000;
  std::ostringstream h;
  h << "VERSION 0.7\nFIELDS x y z";
  for (std::size_t f = 3; f < fields; ++f)
    h << " f" << f;
  h << "\nSIZE";
  for (std::size_t f = 0; f < fields; ++f)
    h << " 4";
  h << "\nTYPE";
  for (std::size_t f = 0; f < fields; ++f)
    h << " F";
  h << "\nCOUNT";
  for (std::size_t f = 0; f < fields; ++f)
    h << " 1";
  h << "\nWIDTH " << n << "\nHEIGHT 1\nPOINTS " << n << "\nDATA binary\n";
  std::string bytes = h.str();
  std::vector<float> rec(fields, 0.5f);
  for (std::size_t i = 0; i < n; ++i)
  {
    const double z = 1.0 - 2.0 * (i + 0.5) / n, s = std::sqrt(1.0 - z * z), t = 2.39996 * static_cast<double>(i);
    rec[0] = static_cast<float>(s * std::cos(t));
    rec[1] = static_cast<float>(s * std::sin(t));
    rec[2] = static_cast<float>(z);
    bytes.append(reinterpret_cast<const char*>(rec.data()), rec.size() * 4);
  }
  std::ofstream(path("wide.pcd"), std::ios::binary) << bytes;
  const std::set<std::string> before = entries();
  r = runTool(kSimplify, path("wide.pcd") + " " + path("w.pcd") + " --stream --memory-limit 64M --quiet");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_EQ(entries(), before) << "a refused run leaves nothing";
  const long needed_mib = suggested(r.err);
  EXPECT_GT(needed_mib, 64);
  r = runTool(kSimplify, path("wide.pcd") + " " + path("w.pcd") + " --stream --quiet --memory-limit " +
                             std::to_string(needed_mib) + "M");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_LT(r.peak_rss_kib, needed_mib * 1024) << "peak RSS " << r.peak_rss_kib / 1024 << " MiB";
}

// Coincident points in the streamed path, across tiles: 30,000 more points at the place of one
// (a sensor writing the same return again and again) and 20,000 points stored twice are merged
// before neighbourhoods, as in memory: the count is exact, the spot is one output point, and the
// rest is simplified as the scan alone (quadratic work in the spot's neighbour searches before:
// minutes, not a second).
TEST_F(StreamCli, CoincidentPointsAreMergedAcrossTiles)
{
  const std::string scan = makeScan("scan.pcd", 60000);
  pcl::PCLPointCloud2 c;
  pcl_ecs::io::readCloud(scan, c);
  const std::size_t n = static_cast<std::size_t>(c.width) * c.height, step = c.point_step;
  std::vector<std::uint8_t> data = c.data;
  for (int i = 0; i < 30000; ++i)
    data.insert(data.end(), c.data.begin(), c.data.begin() + static_cast<std::ptrdiff_t>(step));
  data.insert(data.end(), c.data.begin(), c.data.begin() + static_cast<std::ptrdiff_t>(20000 * step));
  pcl::PCLPointCloud2 spiked = c;
  spiked.data = data;
  spiked.width = static_cast<std::uint32_t>(data.size() / step);
  spiked.height = 1;
  spiked.row_step = spiked.width * static_cast<std::uint32_t>(step);
  pcl_ecs::io::writeCloud(path("spiked.pcd"), pcl_ecs::io::Format::Pcd, spiked, pcl_ecs::io::Encoding::Binary);
  ASSERT_EQ(spiked.width, n + 50000);

  const RunResult a = runTool(kSimplify, scan + " " + path("a.pcd") + " --stream --tile-points 60000 --stats " +
                                             path("a.json"));
  const RunResult b = runTool(kSimplify, path("spiked.pcd") + " " + path("b.pcd") +
                                             " --stream --tile-points 60000 --stats " + path("b.json"));
  ASSERT_EQ(a.code, 0) << a.err;
  ASSERT_EQ(b.code, 0) << b.err;
  const auto ja = nlohmann::json::parse(slurp(path("a.json"))), jb = nlohmann::json::parse(slurp(path("b.json")));
  EXPECT_GE(jb["tiles"]["list"].size(), 2u) << "the test needs several tiles";
  EXPECT_EQ(jb["counts"]["merged_points"].get<std::size_t>(), 50000u + ja["counts"]["merged_points"].get<std::size_t>());
  EXPECT_NE(b.out.find("coincident points merged"), std::string::npos) << b.out;
  pcl::PCLPointCloud2 out;
  pcl_ecs::io::readCloud(path("b.pcd"), out);
  const std::uint32_t x_in = c.fields[static_cast<std::size_t>(pcl_ecs::io::fieldIndex(c.fields, "x"))].offset;
  const std::uint32_t x_out = out.fields[static_cast<std::size_t>(pcl_ecs::io::fieldIndex(out.fields, "x"))].offset;
  std::size_t at_spot = 0;
  for (std::size_t i = 0; i < static_cast<std::size_t>(out.width) * out.height; ++i)
    at_spot += std::memcmp(out.data.data() + i * out.point_step + x_out, c.data.data() + x_in, 12) == 0 ? 1 : 0;
  EXPECT_LE(at_spot, 1u);
  const double na = ja["counts"]["output_points"].get<double>(), nb = jb["counts"]["output_points"].get<double>();
  EXPECT_NEAR(nb, na, 0.03 * na) << "the scan with the spot and the copies is simplified as the scan";
}

// The streamed path is scale-free as the filter is: the bunny in units 1e-24 to 1e30 of its own
// gives the unit-scale run, point for point (to float rounding) (it hung at 1e-24 and kept 11% at
// 1e30 before, when the tiles computed in the input's units).
TEST_F(StreamCli, ExtremeScalesGiveTheUnitScaleResult)
{
  pcl::PCLPointCloud2 blob;
  pcl_ecs::io::readCloud(kShared + "/bunny.pcd", blob);
  pcl::PointCloud<pcl::PointXYZ> bunny;
  pcl_ecs::io::fromCloud(blob, bunny);
  auto write_scaled = [&](double k, const std::string& name) {
    pcl::PointCloud<pcl::PointXYZ> c;
    for (const auto& p : bunny)
      c.push_back(pcl::PointXYZ(static_cast<float>(p.x * k), static_cast<float>(p.y * k), static_cast<float>(p.z * k)));
    pcl::PCLPointCloud2 out;
    pcl::toPCLPointCloud2(c, out);
    pcl_ecs::io::writeCloud(path(name), pcl_ecs::io::Format::Pcd, out, pcl_ecs::io::Encoding::Binary);
  };
  auto simplified = [&](const std::string& name) {
    const RunResult r = runTool(kSimplify, path(name) + " " + path("out_" + name) + " --stream --quiet");
    EXPECT_EQ(r.code, 0) << name << ": " << r.err;
    pcl::PCLPointCloud2 o;
    pcl::PointCloud<pcl::PointXYZ> c;
    if (r.code == 0)
    {
      pcl_ecs::io::readCloud(path("out_" + name), o);
      pcl_ecs::io::fromCloud(o, c);
    }
    return c;
  };
  pcl::PointXYZ lo, hi;
  pcl::getMinMax3D(bunny, lo, hi);
  const double diagonal = (hi.getVector3fMap() - lo.getVector3fMap()).cast<double>().norm();
  write_scaled(1.0, "unit.pcd");
  const auto unit = simplified("unit.pcd");
  ASSERT_GT(unit.size(), 1000u);
  ASSERT_LT(unit.size(), bunny.size() / 5);
  for (const double k : {1e-24, 1e-8, 1e8, 1e30})
  {
    SCOPED_TRACE("scale " + std::to_string(k));
    const std::string name = "scaled_" + std::to_string(k) + ".pcd";
    write_scaled(k, name);
    const auto got = simplified(name);
    ASSERT_EQ(got.size(), unit.size());
    double worst = 0.0;
    for (std::size_t i = 0; i < got.size(); ++i)
      worst = std::max(worst, (got[i].getVector3fMap().cast<double>() / k - unit[i].getVector3fMap().cast<double>()).norm());
    // Scaled inputs are rounded to float, and so is every step after: a few float ulps of L.
    EXPECT_LT(worst, 5e-5 * diagonal) << "largest difference to the unit-scale run, in the bunny's units";
  }
}
