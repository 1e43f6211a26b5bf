// LAS / LAZ in pcl_ecs::io: a cloud of any origin gets a LAS header that holds its coordinates; a
// LAS file read and written again is the same file; a header that lies is refused with what is
// wrong; 64-bit integer fields (a LAS wave packet offset) keep every bit through PCD.
#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/io/cloud_io.h>
#include <pcl_ecs/io/las_io.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <unistd.h>
#include <cstring>
#include <sstream>

#include <gtest/gtest.h>

namespace io = pcl_ecs::io;
using Field = pcl::PCLPointField;

namespace
{
/// A cloud of n zeroed records of the given fields (count 1 each).
pcl::PCLPointCloud2 cloudOf(std::size_t n, std::initializer_list<std::pair<const char*, std::uint8_t>> fields)
{
  pcl::PCLPointCloud2 c;
  for (const auto& [name, type] : fields)
    io::appendField(c, name, type);
  c.width = static_cast<std::uint32_t>(n);
  c.height = 1;
  c.row_step = c.point_step * c.width;
  c.data.assign(n * c.point_step, 0);
  return c;
}

/// A cloud of n points with x y z as double (centimetre UTM), a float intensity and a PCL rgb.
pcl::PCLPointCloud2 utmCloud(std::size_t n)
{
  pcl::PCLPointCloud2 c = cloudOf(n, {{"x", Field::FLOAT64}, {"y", Field::FLOAT64}, {"z", Field::FLOAT64},
                                       {"intensity", Field::FLOAT32}, {"rgb", Field::FLOAT32}});
  const std::uint32_t at = c.point_step;
  for (std::size_t i = 0; i < n; ++i)
  {
    std::uint8_t* p = c.data.data() + i * at;
    const double xyz[3] = {512345.67 + 0.01 * static_cast<double>(i), 4101234.5 - 0.03 * static_cast<double>(i),
                           201.25 + 0.01 * static_cast<double>(i % 7)};
    std::memcpy(p, xyz, 24);
    const float intensity = static_cast<float>(i % 1000);
    std::memcpy(p + 24, &intensity, 4);
    const std::uint32_t rgb = (static_cast<std::uint32_t>(i % 256) << 16) | (7u << 8) | 200u;
    std::memcpy(p + 28, &rgb, 4);
  }
  return c;
}

double valueOf(const pcl::PCLPointCloud2& c, const std::string& name, std::size_t i)
{
  for (const Field& f : c.fields)
    if (f.name == name)
    {
      const std::uint8_t* p = c.data.data() + i * c.point_step + f.offset;
      switch (f.datatype)
      {
      case Field::UINT8: return *p;
      case Field::UINT16: { std::uint16_t v; std::memcpy(&v, p, 2); return v; }
      case Field::FLOAT32: { float v; std::memcpy(&v, p, 4); return v; }
      case Field::FLOAT64: { double v; std::memcpy(&v, p, 8); return v; }
      default: break;
      }
    }
  ADD_FAILURE() << "no field " << name;
  return 0.0;
}

/// A LAS / LAZ file's bytes read whole (parseLas) and, written to `path`, a chunk of `chunk`
/// points at a time (LasStreamReader): each reader's records, or its refusal.
struct ReadBothWays
{
  pcl::PCLPointCloud2 whole;
  std::vector<std::uint8_t> chunked;
  std::string whole_error, chunked_error;
};

ReadBothWays readBothWays(const std::string& bytes, const std::string& path, std::size_t chunk_points)
{
  ReadBothWays r;
  try
  {
    io::parseLas(bytes, r.whole);
  }
  catch (const io::FormatError& e)
  {
    r.whole_error = e.what();
  }
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  try
  {
    io::LasStreamReader reader(path);
    std::vector<std::uint8_t> chunk;
    while (reader.read(chunk_points, chunk) > 0)
      r.chunked.insert(r.chunked.end(), chunk.begin(), chunk.end());
  }
  catch (const io::FormatError& e)
  {
    r.chunked_error = e.what();
  }
  return r;
}

/// Where the item list of the LASzip VLR of `laz` starts (6 bytes an item: type, size, version,
/// u16 each; their count, u16, just before), or npos when it has none.
std::size_t laszipItemsAt(const std::string& laz)
{
  const std::size_t user_id = laz.find("laszip encoded");
  // The VLR header (54 bytes, the user id at its byte 2), then the payload's 34 bytes.
  return user_id == std::string::npos ? user_id : user_id - 2 + 54 + 34;
}

/// The number of items in that list.
std::uint16_t laszipItemCount(const std::string& laz, std::size_t items)
{
  std::uint16_t n = 0;
  std::memcpy(&n, &laz[items - 2], 2);
  return n;
}

/// 300 UTM points (utmCloud) as a LAZ of LAS 1.`minor`, point format `format`, with `extra` extra
/// bytes a record.
std::string utmLaz(std::uint8_t minor, std::uint8_t format, std::size_t extra)
{
  pcl::PCLPointCloud2 read;
  io::LasInfo info;
  io::parseLas(io::lasBytes(utmCloud(300), nullptr, false), read, &info);
  info.version_minor = minor;
  info.point_format = format;
  info.record_length = static_cast<std::uint16_t>(io::lasStandardRecordLength(format) + extra);
  return io::lasBytes(read, &info, true);
}
}  // namespace

TEST(LasIo, ACloudOfAnyOriginGetsAScaleThatHoldsItsCoordinates)
{
  const pcl::PCLPointCloud2 c = utmCloud(500);
  const std::string bytes = io::lasBytes(c, nullptr, false);
  pcl::PCLPointCloud2 back;
  io::LasInfo info;
  io::parseLas(bytes, back, &info);
  EXPECT_EQ(info.version_minor, 2);
  EXPECT_EQ(info.point_format, 2);  // colour, no GPS time
  ASSERT_EQ(back.width, 500u);
  // The finest power of ten that holds ±half the box in 31 bits: the box is 15 m, so 1e-8.
  EXPECT_DOUBLE_EQ(info.scale[0], 1e-8);
  for (std::size_t i = 0; i < 500; ++i)
  {
    double x;
    std::memcpy(&x, c.data.data() + i * c.point_step, 8);
    EXPECT_NEAR(valueOf(back, "x", i), x, 0.5e-8 + 1e-9);
    EXPECT_EQ(valueOf(back, "intensity", i), static_cast<double>(i % 1000));
    EXPECT_EQ(valueOf(back, "red", i), static_cast<double>(i % 256) * 257.0);  // 8-bit colour as LAS's 16
    EXPECT_EQ(valueOf(back, "green", i), 7.0 * 257.0);
  }
}

TEST(LasIo, AFileReadAndWrittenAgainIsTheSameFile)
{
  for (const bool laz : {false, true})
  {
    if (laz && !io::lazSupported())
      continue;
    const std::string first = io::lasBytes(utmCloud(3000), nullptr, laz);
    pcl::PCLPointCloud2 cloud;
    io::LasInfo info;
    io::parseLas(first, cloud, &info);
    EXPECT_EQ(info.compressed, laz);
    EXPECT_EQ(io::lasBytes(cloud, &info, laz), first) << (laz ? "LAZ" : "LAS");
    // And LAZ <-> LAS changes the encoding, not the points.
    pcl::PCLPointCloud2 other;
    io::parseLas(io::lasBytes(cloud, &info, !laz), other);
    EXPECT_EQ(other.data, cloud.data);
  }
}

TEST(LasIo, AHeaderThatLiesIsRefusedWithWhatIsWrong)
{
  const std::string good = io::lasBytes(utmCloud(100), nullptr, false);
  auto expectRefused = [](const std::string& bytes, const std::string& what) {
    pcl::PCLPointCloud2 c;
    try
    {
      io::parseLas(bytes, c);
      ADD_FAILURE() << "accepted; expected: " << what;
    }
    catch (const io::FormatError& e)
    {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  auto patched = [&](std::size_t at, std::uint32_t value, std::size_t size) {
    std::string b = good;
    std::memcpy(&b[at], &value, size);
    return b;
  };
  expectRefused(good.substr(0, good.size() - 1), "truncated");
  expectRefused(patched(107, 101, 4), "truncated");              // one point more than the file holds
  expectRefused(patched(105, 19, 2), "record length");           // shorter than format 2's 26 bytes
  expectRefused(patched(104, 3, 1), "record length");            // format 3 needs 34 bytes, not 26
  expectRefused(patched(96, 100, 4), "outside the file");        // points inside the header
  expectRefused(patched(100, 5, 4), "VLR");
  expectRefused(patched(25, 9, 1), "version");
  expectRefused(patched(104, 6, 1), "needs LAS 1.4");             // a 1.2 header with a 1.4 format
  std::string zero_scale = good;
  std::memset(&zero_scale[131], 0, 8);
  expectRefused(zero_scale, "scale");
  expectRefused("LASF", "truncated");
  expectRefused("PK\x03\x04", "not a LAS file");
  if (!io::lazSupported())
    return;
  // A LAZ file whose compressed points are cut, or whose VLR is not LASzip's.
  const std::string laz = io::lasBytes(utmCloud(100000), nullptr, true);
  expectRefused(laz.substr(0, laz.size() / 2), "compressed points are truncated or corrupt");
  std::string wrong_vlr = laz;
  std::memcpy(&wrong_vlr[227 + 2], "not laszip here", 15);
  expectRefused(wrong_vlr, "no LASzip VLR");
}

TEST(LasIo, SixtyFourBitIntegersKeepEveryBitThroughPcd)
{
  pcl::PCLPointCloud2 c = cloudOf(2, {{"x", Field::FLOAT32}, {"y", Field::FLOAT32}, {"z", Field::FLOAT32},
                                       {"big", Field::UINT64}, {"neg", Field::INT64}});
  const std::uint32_t at = c.point_step;
  const std::uint64_t big[2] = {18446744073709551615ull, 9007199254740993ull};  // 2^64-1, 2^53+1
  const std::int64_t neg[2] = {-9223372036854775807ll - 1, -9007199254740993ll};
  for (int i = 0; i < 2; ++i)
  {
    std::memcpy(c.data.data() + i * at + 12, &big[i], 8);
    std::memcpy(c.data.data() + i * at + 20, &neg[i], 8);
  }
  for (const io::Encoding e : {io::Encoding::Ascii, io::Encoding::Binary, io::Encoding::BinaryCompressed})
  {
    std::ostringstream out;
    io::writePcd(out, c, e);
    pcl::PCLPointCloud2 back;
    io::parsePcd(out.str(), back);
    ASSERT_EQ(back.point_step, c.point_step);
    EXPECT_EQ(back.data, c.data) << "encoding " << static_cast<int>(e);
    EXPECT_EQ(back.fields[3].datatype, Field::UINT64);
    EXPECT_EQ(back.fields[4].datatype, Field::INT64);
  }
}

TEST(LasIo, ChunkedWritingAndReadingGiveTheWholeFileFunctionsBytesAndPoints)
{
  const pcl::PCLPointCloud2 cloud = utmCloud(120001);  // more than two LAZ chunks of 50,000
  const auto dir = std::filesystem::temp_directory_path() / ("pcl_ecs_las_chunks_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  for (const bool laz : {false, true})
  {
    if (laz && !io::lazSupported())
      continue;
    // A LAS 1.4 header with a CRS VLR and an EVLR, as a file read from elsewhere would have.
    pcl::PCLPointCloud2 read;
    io::LasInfo info;
    io::parseLas(io::lasBytes(cloud, nullptr, laz), read, &info);
    info.version_minor = 4;
    io::LasVlr crs;
    crs.user_id = "LASF_Projection";
    crs.record_id = 2112;
    crs.data.assign(100, 'w');
    io::LasVlr evlr = crs;
    evlr.user_id = "pcl_ecs_test";
    evlr.extended = true;
    evlr.data.assign(70000, 'e');  // more than a VLR holds
    info.vlrs = {crs, evlr};
    const std::string whole = io::lasBytes(read, &info, laz);

    const std::string path = (dir / (laz ? "c.laz" : "c.las")).string();
    {
      io::LasStreamWriter w(path, read.fields, read.point_step, info, laz);
      for (std::size_t at = 0; at < read.width; at += 7777)
      {
        const std::size_t n = std::min<std::size_t>(7777, read.width - at);
        w.append(read.data.data() + at * read.point_step, n);
      }
      EXPECT_EQ(w.written(), read.width);
      EXPECT_FALSE(std::filesystem::exists(path)) << "nothing at the path before commit()";
      w.commit();
    }
    std::ifstream f(path, std::ios::binary);
    const std::string chunked((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    EXPECT_TRUE(chunked == whole) << (laz ? "LAZ" : "LAS") << ": " << chunked.size() << " vs " << whole.size() << " bytes";

    io::LasStreamReader r(path);
    EXPECT_EQ(r.points(), read.width);
    EXPECT_EQ(r.pointStep(), read.point_step);
    EXPECT_EQ(r.info().vlrs.size(), 2u);
    std::vector<std::uint8_t> all, chunk;
    while (r.read(10007, chunk) > 0)
      all.insert(all.end(), chunk.begin(), chunk.end());
    EXPECT_EQ(r.remaining(), 0u);
    EXPECT_TRUE(all == read.data) << (laz ? "LAZ" : "LAS");

    // Cut short: refused with the path, at open (the EVLRs are gone) or where the points run out.
    std::filesystem::resize_file(path, chunked.size() - 70000 - 60 - (laz ? 40000 : 400000));
    try
    {
      io::LasStreamReader cut(path);
      while (cut.read(10007, chunk) > 0)
      {
      }
      ADD_FAILURE() << "a cut file read to the end";
    }
    catch (const io::FormatError& e)
    {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  }
  std::filesystem::remove_all(dir);
}

// A LAZ whose chunk-table offset points past the file (a damaged header; the fuzzer found one):
// the whole-file and the chunked reader agree, the same points or the same refusal.
TEST(LasIo, ALazWithItsChunkTableOffsetPastTheEndReadsTheSameBothWays)
{
  if (!io::lazSupported())
    GTEST_SKIP() << "built without LAZ";
  const std::string laz = io::lasBytes(utmCloud(1000), nullptr, true);
  std::uint32_t point_offset = 0;
  std::memcpy(&point_offset, laz.data() + 96, 4);
  const std::string path =
      (std::filesystem::temp_directory_path() / ("pcl_ecs_laz_table_" + std::to_string(::getpid()) + ".laz")).string();
  // The fuzzer's file (its first byte picks the reader), then a good file with the offset changed.
  std::ifstream found(std::string(PCL_ECS_SOURCE_DIR) + "/tests/fuzz/corpus/laz_chunk_table_offset_past_the_end",
                      std::ios::binary);
  const std::string fuzzed((std::istreambuf_iterator<char>(found)), std::istreambuf_iterator<char>());
  ASSERT_GT(fuzzed.size(), 375u);
  std::vector<std::string> files{fuzzed.substr(1)};
  for (const std::int64_t table :
       {std::int64_t{27285480555927152}, std::int64_t{1} << 62, static_cast<std::int64_t>(laz.size()) + 8})
  {
    files.push_back(laz);
    std::memcpy(&files.back()[point_offset], &table, 8);
  }
  for (const std::string& bad : files)
  {
    const std::size_t table = &bad - files.data();
    const ReadBothWays r = readBothWays(bad, path, 333);
    EXPECT_EQ(r.whole_error.empty(), r.chunked_error.empty()) << table << ": " << r.whole_error << " / " << r.chunked_error;
    if (r.whole_error.empty() && r.chunked_error.empty())
      EXPECT_TRUE(r.chunked == r.whole.data) << table;
  }
  std::filesystem::remove(path);
}

// LAZ holds records of at most lazMaxExtraBytes() extra bytes: the codec keeps models for each
// extra byte before its first point, and the fuzzer found a 749-byte LAS 1.4 header claiming
// 63,746 of them that made writing it as LAZ take 2 GB. At the limit LAZ is written and read
// back; one byte more is refused at once when writing, when reading (whole and in chunks), and
// the same records stay writable as LAS.
TEST(LasIo, RecordsWithMoreExtraBytesThanLazHoldsAreRefusedBeforeTheCodecAllocates)
{
  if (!io::lazSupported())
    GTEST_SKIP() << "built without LAZ";
  ASSERT_EQ(io::lazMaxExtraBytes(), 1024u);
  const std::string path =
      (std::filesystem::temp_directory_path() / ("pcl_ecs_laz_extra_" + std::to_string(::getpid()) + ".laz")).string();
  auto expectRefused = [&](const std::string& bytes, const std::string& what) {
    const ReadBothWays r = readBothWays(bytes, path, 100);
    EXPECT_NE(r.whole_error.find(what), std::string::npos) << r.whole_error;
    EXPECT_NE(r.chunked_error.find(what), std::string::npos) << r.chunked_error;
  };
  for (const int format : {1, 6})
  {
    SCOPED_TRACE(format);
    pcl::PCLPointCloud2 read;
    io::LasInfo info;
    io::parseLas(io::lasBytes(utmCloud(300), nullptr, false), read, &info);
    info.point_format = static_cast<std::uint8_t>(format);
    info.version_minor = format >= 6 ? 4 : 2;
    const std::size_t standard = io::lasStandardRecordLength(format);

    info.record_length = static_cast<std::uint16_t>(standard + 1024);
    EXPECT_EQ(io::lazCannotWrite(info), "");
    const std::string laz = io::lasBytes(read, &info, true);
    pcl::PCLPointCloud2 from_laz, from_las;
    io::parseLas(laz, from_laz);
    io::parseLas(io::lasBytes(read, &info, false), from_las);
    EXPECT_EQ(from_laz.point_step, from_las.point_step);
    EXPECT_TRUE(from_laz.data == from_las.data);

    // One byte more: the header's record length and the LASzip VLR's extra-bytes item, both + 1.
    std::string more = laz;
    const std::uint16_t longer = info.record_length + 1;
    std::memcpy(&more[105], &longer, 2);
    const std::size_t items = laszipItemsAt(more);
    ASSERT_NE(items, std::string::npos);
    const std::uint16_t n_items = laszipItemCount(more, items);
    int patched = 0;
    for (std::size_t i = 0; i < n_items; ++i)
    {
      std::uint16_t type = 0, size = 0;
      std::memcpy(&type, &more[items + 6 * i], 2);
      std::memcpy(&size, &more[items + 6 * i + 2], 2);
      if (type == 0 || type == 14)  // Byte (formats 0-5), Byte14 (6-10)
      {
        EXPECT_EQ(size, 1024u);
        ++size;
        std::memcpy(&more[items + 6 * i + 2], &size, 2);
        ++patched;
      }
    }
    ASSERT_EQ(patched, 1);
    expectRefused(more, "1025 extra bytes");

    info.record_length = longer;
    EXPECT_NE(io::lazCannotWrite(info).find("1025 extra bytes"), std::string::npos);
    try
    {
      io::lasBytes(read, &info, true);
      ADD_FAILURE() << "written as LAZ";
    }
    catch (const io::FormatError& e)
    {
      EXPECT_NE(std::string(e.what()).find("1025 extra bytes"), std::string::npos) << e.what();
    }
    EXPECT_THROW(io::LasStreamWriter(path, read.fields, read.point_step, info, true), io::FormatError);
    pcl::PCLPointCloud2 as_las;
    io::parseLas(io::lasBytes(read, &info, false), as_las);
    EXPECT_EQ(as_las.width, 300u);
  }

  // The fuzzer's file (its first byte picks the reader): no points, so it reads; written as LAZ
  // it is refused, at once.
  std::ifstream found(std::string(PCL_ECS_SOURCE_DIR) + "/tests/fuzz/corpus/laz_63746_extra_bytes", std::ios::binary);
  const std::string fuzzed((std::istreambuf_iterator<char>(found)), std::istreambuf_iterator<char>());
  ASSERT_EQ(fuzzed.size(), 750u);
  pcl::PCLPointCloud2 none;
  io::LasInfo none_info;
  io::parseLas(fuzzed.substr(1), none, &none_info);
  EXPECT_EQ(none.width, 0u);
  EXPECT_NE(io::lazCannotWrite(none_info).find("63746 extra bytes"), std::string::npos);
  EXPECT_THROW(io::lasBytes(none, &none_info, true), io::FormatError);
  std::filesystem::remove(path);
}

// A LASzip VLR lists each part of a point format once; the codec keeps models for every item it
// lists, so a forged list is refused before it allocates (the same bound as the extra bytes'):
// here the 8 extra bytes of format 1 relabelled as a second GPS time, which keeps the sizes right.
TEST(LasIo, ALazWhoseVlrListsAnItemTwiceIsRefused)
{
  if (!io::lazSupported())
    GTEST_SKIP() << "built without LAZ";
  std::string laz = utmLaz(2, 1, 8);
  const std::size_t items = laszipItemsAt(laz);
  ASSERT_NE(items, std::string::npos);
  ASSERT_EQ(laszipItemCount(laz, items), 3u);  // Point10, GpsTime, Byte(8)
  std::uint16_t type = 0, size = 0;
  std::memcpy(&type, &laz[items + 12], 2);
  std::memcpy(&size, &laz[items + 14], 2);
  ASSERT_EQ(type, 0u);
  ASSERT_EQ(size, 8u);
  pcl::PCLPointCloud2 good;
  io::parseLas(laz, good);  // as written: read
  EXPECT_EQ(good.width, 300u);
  type = 7;  // GpsTime11
  std::memcpy(&laz[items + 12], &type, 2);
  const std::string path =
      (std::filesystem::temp_directory_path() / ("pcl_ecs_laz_items_" + std::to_string(::getpid()) + ".laz")).string();
  const ReadBothWays r = readBothWays(laz, path, 100);
  EXPECT_NE(r.whole_error.find("twice"), std::string::npos) << r.whole_error;
  EXPECT_NE(r.chunked_error.find("twice"), std::string::npos) << r.chunked_error;
  std::filesystem::remove(path);
}

TEST(LasIo, ALazOfPointFormats6To10WithoutTheLayeredCompressorIsRefused)
{
  // Point format 6 is compressed in layers (compressor 3); a LASzip VLR that names its items with
  // the point-wise compressors (1, 2) made the codec read layer sizes the file does not hold and
  // allocate them (1.8 GB for an 893-byte file the fuzzer made: tests/fuzz/corpus/laz_pointwise_layered).
  if (!io::lazSupported())
    GTEST_SKIP() << "built without LAZ";
  const std::string laz = utmLaz(4, 6, 0);
  const std::size_t items = laszipItemsAt(laz);
  ASSERT_NE(items, std::string::npos);
  std::uint16_t compressor = 0;
  std::memcpy(&compressor, &laz[items - 34], 2);
  ASSERT_EQ(compressor, 3u);
  pcl::PCLPointCloud2 good;
  io::parseLas(laz, good);
  EXPECT_EQ(good.width, 300u);
  const std::string path =
      (std::filesystem::temp_directory_path() / ("pcl_ecs_laz_layers_" + std::to_string(::getpid()) + ".laz")).string();
  for (const std::uint16_t pointwise : {1, 2})
  {
    std::string bad = laz;
    std::memcpy(&bad[items - 34], &pointwise, 2);
    const ReadBothWays r = readBothWays(bad, path, 100);
    EXPECT_NE(r.whole_error.find("not the layered one"), std::string::npos) << r.whole_error;
    EXPECT_NE(r.chunked_error.find("not the layered one"), std::string::npos) << r.chunked_error;
  }
  std::ifstream found(std::string(PCL_ECS_SOURCE_DIR) + "/tests/fuzz/corpus/laz_pointwise_layered", std::ios::binary);
  ASSERT_TRUE(found);
  const std::string fuzzed((std::istreambuf_iterator<char>(found)), std::istreambuf_iterator<char>());
  const ReadBothWays r = readBothWays(fuzzed.substr(1), path, 100);  // the fuzz target's first byte picks the reader
  EXPECT_NE(r.whole_error.find("with compressor 1"), std::string::npos) << r.whole_error;
  EXPECT_NE(r.chunked_error.find("with compressor 1"), std::string::npos) << r.chunked_error;
  std::filesystem::remove(path);
}

namespace
{
/// The Extra Bytes VLR of `info` (LASF_Spec 4), or null.
const io::LasVlr* extraBytesVlr(const io::LasInfo& info)
{
  for (const io::LasVlr& v : info.vlrs)
    if (v.user_id == "LASF_Spec" && v.record_id == 4)
      return &v;
  return nullptr;
}

/// Expects `f` to throw a FormatError whose message holds `says`.
template <typename F>
void expectFormatError(F f, const std::string& says)
{
  try
  {
    f();
    ADD_FAILURE() << "no error; expected one saying \"" << says << "\"";
  }
  catch (const io::FormatError& e)
  {
    EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
  }
}
}  // namespace

TEST(LasIo, CloudFieldsBecomeExtraDimensionsThatTheExtraBytesVlrDescribes)
{
  // A cloud with a uint8 and a float field written as LAS (and LAZ): 5 bytes after the format's
  // fields, described in the VLR by the LAS specification's layout (type at byte 2, name at 4).
  const std::size_t n = 60;
  pcl::PCLPointCloud2 c = utmCloud(n);
  io::appendField(c, "ecs_label", Field::UINT8);
  io::appendField(c, "ecs_radius", Field::FLOAT32);
  std::vector<std::uint8_t> data(n * c.point_step, 0);
  const std::size_t old_step = c.point_step - 5;
  for (std::size_t i = 0; i < n; ++i)
  {
    std::memcpy(data.data() + i * c.point_step, utmCloud(n).data.data() + i * old_step, old_step);
    data[i * c.point_step + old_step] = static_cast<std::uint8_t>(1 + i % 2);
    const float r = 0.25f * static_cast<float>(i);
    std::memcpy(data.data() + i * c.point_step + old_step + 1, &r, 4);
  }
  c.data = data;
  c.row_step = c.point_step * c.width;
  const std::vector<io::ExtraDimension> dims = {{"ecs_label", "labels"}, {"ecs_radius", "radii"}};
  io::LasInfo info = io::lasInfoFor(c, nullptr);
  ASSERT_EQ(info.point_format, 2);  // colour
  io::addLasExtraDimensions(info, c.fields, dims);
  EXPECT_EQ(info.record_length, io::lasStandardRecordLength(2) + 5);
  const io::LasVlr* vlr = extraBytesVlr(info);
  ASSERT_NE(vlr, nullptr);
  ASSERT_EQ(vlr->data.size(), 2u * 192u);
  EXPECT_EQ(vlr->data[2], 1u);  // unsigned char
  EXPECT_STREQ(reinterpret_cast<const char*>(&vlr->data[4]), "ecs_label");
  EXPECT_EQ(vlr->data[192 + 2], 9u);  // float
  EXPECT_STREQ(reinterpret_cast<const char*>(&vlr->data[192 + 4]), "ecs_radius");
  EXPECT_STREQ(reinterpret_cast<const char*>(&vlr->data[192 + 160]), "radii");

  for (const bool laz : {false, true})
  {
    if (laz && !io::lazSupported())
      continue;
    pcl::PCLPointCloud2 back;
    io::LasInfo back_info;
    const std::string bytes = io::lasBytes(c, &info, laz);
    io::parseLas(bytes, back, &back_info);
    ASSERT_EQ(back.width, n);
    EXPECT_EQ(back_info.record_length, info.record_length);
    ASSERT_NE(extraBytesVlr(back_info), nullptr);
    EXPECT_EQ(extraBytesVlr(back_info)->data, vlr->data);
    // Read back as fields of their own, named and typed as the VLR says.
    EXPECT_LT(io::fieldIndex(back.fields, "extra_bytes"), 0);
    const int fl = io::fieldIndex(back.fields, "ecs_label"), fr = io::fieldIndex(back.fields, "ecs_radius");
    ASSERT_GE(fl, 0);
    ASSERT_GE(fr, 0);
    EXPECT_EQ(back.fields[static_cast<std::size_t>(fl)].datatype, Field::UINT8);
    EXPECT_EQ(back.fields[static_cast<std::size_t>(fr)].datatype, Field::FLOAT32);
    for (std::size_t i = 0; i < n; ++i)
    {
      const std::string what = "point " + std::to_string(i) + (laz ? " (LAZ)" : "");
      EXPECT_EQ(valueOf(back, "ecs_label", i), static_cast<double>(1 + i % 2)) << what;
      EXPECT_EQ(valueOf(back, "ecs_radius", i), 0.25 * static_cast<double>(i)) << what;
    }
    // Read and written again: the same file.
    EXPECT_EQ(io::lasBytes(back, &back_info, laz), bytes);

    // Written again with the same dimensions (a file of ours simplified again): the records hold
    // them already, their bytes are written over, and the file is the one written before.
    io::LasInfo again = back_info;
    io::addLasExtraDimensions(again, c.fields, dims);
    EXPECT_EQ(again.record_length, info.record_length);
    EXPECT_EQ(extraBytesVlr(again)->data, vlr->data);
    EXPECT_EQ(io::lasBytes(c, &again, laz), io::lasBytes(c, &info, laz));
  }
}

TEST(LasIo, ExtraBytesNoVlrDescribesAreDescribedAsUndocumentedFirst)
{
  // Records of format 0 with 3 extra bytes and no Extra Bytes VLR: a label goes after them, the VLR
  // says "3 undocumented bytes" (type 0, options 3), then the label.
  const std::size_t n = 10;
  pcl::PCLPointCloud2 c = cloudOf(n, {{"x", Field::FLOAT64}, {"y", Field::FLOAT64}, {"z", Field::FLOAT64}});
  io::appendField(c, "extra_bytes", Field::UINT8, 3);
  io::appendField(c, "ecs_label", Field::UINT8);
  c.data.assign(n * c.point_step, 0);
  for (std::size_t i = 0; i < n; ++i)
  {
    std::uint8_t* p = c.data.data() + i * c.point_step;
    const double xyz[3] = {static_cast<double>(i), 2.0 * static_cast<double>(i), 1.0};
    std::memcpy(p, xyz, 24);
    p[24] = 7;
    p[25] = 8;
    p[26] = static_cast<std::uint8_t>(i);
    p[27] = 2;
  }
  io::LasInfo info = io::lasInfoFor(c, nullptr);
  info.record_length = static_cast<std::uint16_t>(io::lasStandardRecordLength(0) + 3);
  io::addLasExtraDimensions(info, c.fields, {{"ecs_label", ""}});
  EXPECT_EQ(info.record_length, io::lasStandardRecordLength(0) + 4);
  const io::LasVlr* vlr = extraBytesVlr(info);
  ASSERT_NE(vlr, nullptr);
  ASSERT_EQ(vlr->data.size(), 2u * 192u);
  EXPECT_EQ(vlr->data[2], 0u);
  EXPECT_EQ(vlr->data[3], 3u);
  EXPECT_EQ(vlr->data[192 + 2], 1u);
  pcl::PCLPointCloud2 back;
  io::parseLas(io::lasBytes(c, &info, false), back);
  const int fe = io::fieldIndex(back.fields, "extra_bytes");
  ASSERT_GE(fe, 0);
  ASSERT_EQ(back.fields[static_cast<std::size_t>(fe)].count, 4u);
  for (std::size_t i = 0; i < n; ++i)
  {
    const std::uint8_t* e = back.data.data() + i * back.point_step + back.fields[static_cast<std::size_t>(fe)].offset;
    EXPECT_EQ(std::vector<int>(e, e + 4), (std::vector<int>{7, 8, static_cast<int>(i), 2})) << "point " << i;
  }
}

TEST(LasIo, ExtraBytesAreOneFieldUnlessTheVlrNamesEachAsAPlainNumber)
{
  // Two float dimensions named in the VLR: two fields. Each way the VLR can fail to name them
  // plainly (a LAS dimension's name, a name with a space, one name twice, a scale, a 3-vector,
  // fewer bytes described than the records hold): one field `extra_bytes` of 8 bytes. Every file
  // is read and written again byte for byte.
  const std::size_t n = 20;
  pcl::PCLPointCloud2 c = cloudOf(n, {{"x", Field::FLOAT64}, {"y", Field::FLOAT64}, {"z", Field::FLOAT64},
                                      {"a", Field::FLOAT32}, {"b", Field::FLOAT32}});
  for (std::size_t i = 0; i < n; ++i)
  {
    std::uint8_t* p = c.data.data() + i * c.point_step;
    const double xyz[3] = {static_cast<double>(i), static_cast<double>(i % 5), 1.0};
    const float ab[2] = {static_cast<float>(i) + 0.5f, -static_cast<float>(i)};
    std::memcpy(p, xyz, 24);
    std::memcpy(p + 24, ab, 8);
  }
  io::LasInfo named = io::lasInfoFor(c, nullptr);
  io::addLasExtraDimensions(named, c.fields, {{"a", ""}, {"b", ""}});
  auto fieldsOf = [&](const io::LasInfo& info) {
    pcl::PCLPointCloud2 back;
    const std::string bytes = io::lasBytes(c, &info, false);
    io::LasInfo back_info;
    io::parseLas(bytes, back, &back_info);
    EXPECT_EQ(io::lasBytes(back, &back_info, false), bytes);
    std::string names;
    for (const Field& f : back.fields)  // the fields after point format 0's
      if (f.offset >= back.point_step - 8)
        names += f.name + "(" + std::to_string(f.count) + ") ";
    return names;
  };
  EXPECT_EQ(fieldsOf(named), "a(1) b(1) ");
  auto patched = [&](std::size_t at, const void* bytes, std::size_t len) {
    io::LasInfo i = named;
    for (io::LasVlr& v : i.vlrs)
      if (v.user_id == "LASF_Spec" && v.record_id == 4)
        std::memcpy(v.data.data() + at, bytes, len);
    return i;
  };
  const std::uint8_t scaled = 0x08, vector3 = 29;  // options: scale given; 3 × float
  EXPECT_EQ(fieldsOf(patched(192 + 4, "intensity", 10)), "extra_bytes(8) ");
  EXPECT_EQ(fieldsOf(patched(192 + 4, "b c", 4)), "extra_bytes(8) ");
  EXPECT_EQ(fieldsOf(patched(192 + 4, "a", 2)), "extra_bytes(8) ");
  EXPECT_EQ(fieldsOf(patched(192 + 3, &scaled, 1)), "extra_bytes(8) ");
  io::LasInfo one = patched(2, &vector3, 1);  // the first is 12 bytes now: more than the records
  for (io::LasVlr& v : one.vlrs)
    if (v.user_id == "LASF_Spec")
      v.data.resize(192);
  EXPECT_EQ(fieldsOf(one), "extra_bytes(8) ");
  io::LasInfo short_vlr = named;
  for (io::LasVlr& v : short_vlr.vlrs)
    if (v.user_id == "LASF_Spec")
      v.data.resize(192);  // describes "a" alone
  EXPECT_EQ(fieldsOf(short_vlr), "extra_bytes(8) ");
}

TEST(LasIo, ExtraDimensionsThatCannotBeAddedAreRefusedWithWhy)
{
  pcl::PCLPointCloud2 c = cloudOf(4, {{"x", Field::FLOAT64}, {"y", Field::FLOAT64}, {"z", Field::FLOAT64},
                                      {"ecs_label", Field::UINT8}, {"ecs_radius", Field::FLOAT32}});
  io::appendField(c, "normal", Field::FLOAT32, 3);  // the records grow with it
  c.row_step = c.point_step * c.width;
  c.data.assign(static_cast<std::size_t>(c.width) * c.point_step, 0);
  const io::LasInfo plain = io::lasInfoFor(c, nullptr);
  expectFormatError([&] { io::LasInfo i = plain; io::addLasExtraDimensions(i, c.fields, {{"missing", ""}}); },
                    "no field \"missing\"");
  expectFormatError([&] { io::LasInfo i = plain; io::addLasExtraDimensions(i, c.fields, {{"normal", ""}}); },
                    "not one number");
  pcl::PCLPointCloud2 named = cloudOf(1, {{"intensity", Field::UINT16}});
  expectFormatError([&] { io::LasInfo i = plain; io::addLasExtraDimensions(i, named.fields, {{"intensity", ""}}); },
                    "name of a LAS dimension");
  // A dimension of that name with another type.
  io::LasInfo labelled = plain;
  io::addLasExtraDimensions(labelled, c.fields, {{"ecs_label", ""}});
  pcl::PCLPointCloud2 other = cloudOf(1, {{"ecs_label", Field::FLOAT32}});
  expectFormatError([&] { io::LasInfo i = labelled; io::addLasExtraDimensions(i, other.fields, {{"ecs_label", ""}}); },
                    "another type");
  // A VLR that is not whole descriptors, or describes more bytes than the records hold.
  io::LasInfo cut = labelled;
  for (io::LasVlr& v : cut.vlrs)
    v.data.resize(100);
  expectFormatError([&] { io::addLasExtraDimensions(cut, c.fields, {{"ecs_radius", ""}}); }, "192-byte");
  io::LasInfo short_records = labelled;
  short_records.record_length = static_cast<std::uint16_t>(short_records.record_length - 1);
  expectFormatError([&] { io::addLasExtraDimensions(short_records, c.fields, {{"ecs_radius", ""}}); },
                    "describes 1 bytes but its records hold 0");
  // A record past 65,535 bytes.
  io::LasInfo wide = plain;
  wide.record_length = 65533;
  expectFormatError([&] { io::addLasExtraDimensions(wide, c.fields, {{"ecs_radius", ""}}); }, "65,535");
}
