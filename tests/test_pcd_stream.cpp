// The streaming PCD reader and writer: every encoding read chunk by chunk gives exactly what PCL's
// own reader gives; the writer's files are read back by PCL; bad files are refused with a message.
#include "cli/cli_fixture.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/io/pcd_stream.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

namespace fs = std::filesystem;
using namespace pcl_ecs::io;

namespace
{
class PcdStream : public pcl_ecs_test::TempDirTest
{
protected:
  /// A cloud with several field types; smooth coordinates so LZF finds back references.
  static pcl::PointCloud<pcl::PointXYZRGBNormal> makeCloud(std::size_t n)
  {
    pcl::PointCloud<pcl::PointXYZRGBNormal> c;
    std::mt19937 rng(3);
    std::uniform_int_distribution<int> col(0, 255);
    for (std::size_t i = 0; i < n; ++i)
    {
      pcl::PointXYZRGBNormal p;
      p.x = static_cast<float>(i % 1000) * 0.01f;
      p.y = static_cast<float>(i / 1000) * 0.01f;
      p.z = std::sin(p.x) * std::cos(p.y);
      p.r = static_cast<std::uint8_t>(col(rng));
      p.g = static_cast<std::uint8_t>(i % 7);
      p.b = 9;
      p.normal_x = 0.f;
      p.normal_y = 0.6f;
      p.normal_z = 0.8f;
      p.curvature = static_cast<float>(i) * 1e-3f;
      c.push_back(p);
    }
    return c;
  }

  /// All records of `file` read `chunk` points at a time.
  static std::vector<std::uint8_t> readAll(const std::string& file, std::size_t chunk, PcdHeader* header = nullptr)
  {
    PcdStreamReader r(file);
    if (header)
      *header = r.header();
    std::vector<std::uint8_t> all, part;
    while (r.read(chunk, part) > 0)
      all.insert(all.end(), part.begin(), part.end());
    EXPECT_EQ(r.remaining(), 0u);
    return all;
  }
};

/// Compares the streamed records with PCL's reading of the same file, field by field.
void expectSameAsPcl(const std::string& file, const std::vector<std::uint8_t>& records, const PcdHeader& h)
{
  pcl::PCLPointCloud2 blob;
  ASSERT_EQ(pcl::io::loadPCDFile(file, blob), 0);
  ASSERT_EQ(static_cast<std::uint64_t>(blob.width) * blob.height, h.points);
  ASSERT_EQ(records.size(), h.points * h.point_step);
  for (const auto& f : h.fields)
  {
    const auto it = std::find_if(blob.fields.begin(), blob.fields.end(), [&](const auto& g) { return g.name == f.name; });
    ASSERT_NE(it, blob.fields.end()) << f.name;
    const std::size_t size = pcl::getFieldSize(f.datatype) * f.count;
    for (std::uint64_t i = 0; i < h.points; ++i)
      ASSERT_EQ(std::memcmp(records.data() + i * h.point_step + f.offset, blob.data.data() + i * blob.point_step + it->offset, size), 0)
          << "field " << f.name << " of point " << i;
  }
}
}  // namespace

TEST_F(PcdStream, EveryEncodingReadsLikePclInAnyChunkSize)
{
  const auto cloud = makeCloud(150000);  // 150k points: LZF back references across chunks
  pcl::PCDWriter w;
  ASSERT_EQ(w.writeASCII(path("a.pcd"), cloud), 0);
  ASSERT_EQ(w.writeBinary(path("b.pcd"), cloud), 0);
  ASSERT_EQ(w.writeBinaryCompressed(path("c.pcd"), cloud), 0);
  for (const char* name : {"a.pcd", "b.pcd", "c.pcd"})
    for (const std::size_t chunk : {std::size_t{777}, std::size_t{65536}, std::size_t{1000000}})
    {
      PcdHeader h;
      const auto records = readAll(path(name), chunk, &h);
      SCOPED_TRACE(std::string(name) + " chunk " + std::to_string(chunk));
      expectSameAsPcl(path(name), records, h);
    }
}

TEST_F(PcdStream, RewindStartsAgain)
{
  pcl::PCDWriter w;
  ASSERT_EQ(w.writeBinaryCompressed(path("c.pcd"), makeCloud(5000)), 0);
  PcdStreamReader r(path("c.pcd"));
  std::vector<std::uint8_t> first, again;
  r.read(100, first);
  r.read(1000, again);
  r.rewind();
  r.read(100, again);
  EXPECT_EQ(first, again);
  EXPECT_EQ(r.remaining(), 4900u);
}

TEST_F(PcdStream, WriterOutputIsReadByPclAndCommittedOnlyOnCommit)
{
  const auto cloud = makeCloud(3000);
  pcl::PCLPointCloud2 blob;
  pcl::toPCLPointCloud2(cloud, blob);
  std::array<double, 7> vp{{1, 2, 3, 1, 0, 0, 0}};
  {
    PcdStreamWriter w(path("out.pcd"), blob.fields, blob.point_step, vp);
    w.append(blob.data.data(), 1000);
    w.append(blob.data.data() + 1000 * blob.point_step, 2000);
    EXPECT_FALSE(fs::exists(path("out.pcd")));
    w.commit();
  }
  pcl::PCLPointCloud2 back;
  Eigen::Vector4f origin;
  Eigen::Quaternionf orientation;
  ASSERT_EQ(pcl::io::loadPCDFile(path("out.pcd"), back, origin, orientation), 0);
  EXPECT_EQ(back.width, 3000u);
  pcl::PointCloud<pcl::PointXYZRGBNormal> read;
  pcl_ecs::io::fromCloud(back, read);
  ASSERT_EQ(read.size(), cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i)
  {
    ASSERT_EQ(read[i].getVector3fMap(), cloud[i].getVector3fMap()) << i;
    ASSERT_EQ(read[i].rgba, cloud[i].rgba) << i;
    ASSERT_EQ(read[i].getNormalVector3fMap(), cloud[i].getNormalVector3fMap()) << i;
    ASSERT_EQ(read[i].curvature, cloud[i].curvature) << i;
  }
  EXPECT_FLOAT_EQ(origin.x(), 1.f);
  EXPECT_FLOAT_EQ(origin.z(), 3.f);
  {
    PcdStreamWriter w(path("never.pcd"), blob.fields, blob.point_step, vp);
    w.append(blob.data.data(), 10);
  }  // destroyed without commit
  EXPECT_FALSE(fs::exists(path("never.pcd")));
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_EQ(e.path().filename(), "out.pcd") << "left behind: " << e.path();
}

TEST_F(PcdStream, BadFilesAreRefusedWithTheReason)
{
  EXPECT_THROW(PcdStreamReader(path("missing.pcd")), FileError);
  std::ofstream(path("empty.pcd")).close();
  try
  {
    PcdStreamReader r(path("empty.pcd"));
    FAIL() << "an empty file was accepted";
  }
  catch (const FormatError& e)
  {
    EXPECT_NE(std::string(e.what()).find("empty"), std::string::npos) << e.what();
  }
  pcl::PCDWriter w;
  const auto cloud = makeCloud(2000);
  ASSERT_EQ(w.writeBinary(path("b.pcd"), cloud), 0);
  ASSERT_EQ(w.writeBinaryCompressed(path("c.pcd"), cloud), 0);
  ASSERT_EQ(w.writeASCII(path("a.pcd"), cloud), 0);
  // Truncated binary: refused up front (the size is known from the header).
  fs::resize_file(path("b.pcd"), fs::file_size(path("b.pcd")) - 100);
  try
  {
    PcdStreamReader r(path("b.pcd"));
    FAIL() << "a truncated file was accepted";
  }
  catch (const FormatError& e)
  {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  // Corrupt compressed block: bytes flipped in the middle.
  {
    std::fstream f(path("c.pcd"), std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(static_cast<std::streamoff>(fs::file_size(path("c.pcd")) / 2));
    const char junk[64] = {};
    f.write(junk, sizeof junk);
  }
  EXPECT_THROW(readAll(path("c.pcd"), 500), FormatError);
  // ASCII with a word where a number belongs, and ASCII cut short.
  std::string text;
  {
    std::ifstream in(path("a.pcd"));
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const std::size_t data = text.find("DATA ascii\n") + 11;
  std::string bad = text;
  bad.replace(data, 1, "x");
  std::ofstream(path("bad.pcd")) << bad;
  try
  {
    readAll(path("bad.pcd"), 100);
    FAIL() << "a word in the data was accepted";
  }
  catch (const FormatError& e)
  {
    EXPECT_NE(std::string(e.what()).find("not a number"), std::string::npos) << e.what();
  }
  std::ofstream(path("short.pcd")) << text.substr(0, data + 300);
  EXPECT_THROW(readAll(path("short.pcd"), 100), FormatError);
  // No x field.
  std::ofstream(path("nox.pcd")) << "FIELDS a b c\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nPOINTS 1\nDATA ascii\n1 2 3\n";
  PcdStreamReader r(path("nox.pcd"));
  EXPECT_THROW(XyzAccess{r.header()}, FormatError);
}
