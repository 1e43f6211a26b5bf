// libFuzzer target over our PCD, PLY and XYZ parsers: the first byte picks the parser, the rest is
// the file. Any input must either parse or throw FormatError; a crash, a sanitizer report or an
// allocation beyond the RSS limit is a bug.
#include <pcl_ecs/io/cloud_io.h>

#include <cstddef>
#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  if (size < 1)
    return 0;
  const std::string bytes(reinterpret_cast<const char*>(data + 1), size - 1);
  pcl::PCLPointCloud2 cloud;
  try
  {
    switch (data[0] % 3)
    {
    case 0: pcl_ecs::io::parsePcd(bytes, cloud); break;
    case 1: pcl_ecs::io::parsePly(bytes, cloud); break;
    default: pcl_ecs::io::parseXyz(bytes, cloud); break;
    }
    // What parsed must be self-consistent.
    const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
    if (cloud.data.size() != n * cloud.point_step)
      __builtin_trap();
  }
  catch (const pcl_ecs::io::FormatError&)
  {
  }
  return 0;
}
