// libFuzzer target over our PCD, PLY, XYZ and LAS / LAZ parsers: the first byte picks the parser,
// the rest is the file. Any input must either parse or throw FormatError; a crash, a sanitizer report or an
// allocation beyond the RSS limit is a bug. What parses is also converted to a point type (every
// field type through io::fromCloud) and written as PCD, which must parse again to the same
// packed records. A PLY or LAS header's probe must agree with the parser, and so must the chunked
// LAS reader; a LAS file read is written again as LAS (or LAZ), which must parse to the same points.
#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/io/cloud_io.h>
#include <pcl_ecs/io/las_io.h>

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <pcl/point_types.h>

namespace
{
/// `bytes` as a file read by LasStreamReader in chunks of 777 points; false when it is refused.
bool readInChunks(const std::string& bytes, std::vector<std::uint8_t>& records)
{
  static const std::string path = "/tmp/pcl_ecs_fuzz_" + std::to_string(::getpid()) + ".las";
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  try
  {
    pcl_ecs::io::LasStreamReader r(path);
    std::vector<std::uint8_t> chunk;
    while (r.read(777, chunk) > 0)
      records.insert(records.end(), chunk.begin(), chunk.end());
    return true;
  }
  catch (const pcl_ecs::io::FormatError&)
  {
    return false;
  }
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  if (size < 1)
    return 0;
  const std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  pcl::PCLPointCloud2 cloud;
  try
  {
    switch (data[0] % 4)
    {
    case 0: pcl_ecs::io::parsePcd(bytes, cloud); break;
    case 1:
    {
      // The header probe (which refuses a body the file cannot hold, unread) must agree with the
      // parser on whatever the parser accepts.
      std::uint64_t probed = 0;
      bool probe_ok = true;
      try
      {
        std::istringstream in(bytes);
        probed = pcl_ecs::io::probePly(in, bytes.size()).points;
      }
      catch (const pcl_ecs::io::FormatError&)
      {
        probe_ok = false;
      }
      pcl_ecs::io::parsePly(bytes, cloud);
      if (!probe_ok || probed != static_cast<std::uint64_t>(cloud.width) * cloud.height)
        __builtin_trap();
      break;
    }
    case 2: pcl_ecs::io::parseXyz(bytes, cloud); break;
    default:
    {
      std::uint64_t probed = 0, step = 0;
      bool probe_ok = true;
      try
      {
        pcl_ecs::io::probeLas(bytes.substr(0, 375), bytes.size(), probed, step);
      }
      catch (const pcl_ecs::io::FormatError&)
      {
        probe_ok = false;
      }
      // A LAZ header may claim up to 5,000 bytes of records per compressed byte (a cloud of one
      // point repeated compresses about 2,800 times): such clouds are read, but not here, where
      // the copies below would pass the RSS limit.
      if (probe_ok && probed * step > (32u << 20))
        return 0;
      // The chunked reader (--stream's) must agree with the whole-file parser: the same records, or
      // a refusal of what the parser refuses.
      std::vector<std::uint8_t> chunked;
      const bool chunked_ok = readInChunks(bytes, chunked);
      pcl_ecs::io::LasInfo info;
      try
      {
        pcl_ecs::io::parseLas(bytes, cloud, &info);
      }
      catch (const pcl_ecs::io::FormatError&)
      {
        if (chunked_ok)
          __builtin_trap();
        throw;
      }
      if (!chunked_ok || chunked != cloud.data)
        __builtin_trap();
      if (!probe_ok || probed != cloud.width || step != cloud.point_step)
        __builtin_trap();
      std::string las;
      try
      {
        las = pcl_ecs::io::lasBytes(cloud, &info, (data[0] / 4) % 2 == 1);
      }
      catch (const pcl_ecs::io::FormatError&)
      {
        break;  // a coordinate its own scale and offset cannot hold again (a header of extremes)
      }
      pcl::PCLPointCloud2 back;
      try
      {
        pcl_ecs::io::parseLas(las, back);
      }
      catch (const pcl_ecs::io::FormatError&)
      {
        __builtin_trap();  // what we write must read back
      }
      if (back.width != cloud.width || back.point_step != cloud.point_step)
        __builtin_trap();
      break;
    }
    }
    // What parsed must be self-consistent.
    const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
    if (cloud.data.size() != n * cloud.point_step)
      __builtin_trap();
    pcl::PointCloud<pcl::PointXYZRGBNormal> typed;
    pcl_ecs::io::fromCloud(cloud, typed, pcl_ecs::io::boundingBoxCentre(cloud));
    if (typed.size() != n)
      __builtin_trap();
    std::ostringstream written;
    pcl_ecs::io::writePcd(written, cloud, static_cast<pcl_ecs::io::Encoding>(data[0] / 4 % 3));
    pcl::PCLPointCloud2 again;
    try
    {
      pcl_ecs::io::parsePcd(written.str(), again);
    }
    catch (const pcl_ecs::io::FormatError&)
    {
      if (n > 0)
        __builtin_trap();  // what we write must read back
      return 0;
    }
    const pcl::PCLPointCloud2 packed = pcl_ecs::io::packedCloud(cloud);
    if (again.point_step != packed.point_step || again.fields.size() != packed.fields.size() ||
        again.data.size() != packed.data.size())
      __builtin_trap();
  }
  catch (const pcl_ecs::io::FormatError&)
  {
  }
  return 0;
}
