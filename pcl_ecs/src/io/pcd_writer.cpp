// The one PCD writer of every tool and of the streaming path: packed records (no padding and no
// '_' fields, COUNT >= 1), fields in record order, ascii / binary / binary_compressed.
#include "io_detail.h"

#include <pcl_ecs/io/cloud_convert.h>

#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iomanip>
#include <sstream>

#include <pcl/io/lzf.h>

namespace pcl_ecs
{
namespace io
{

namespace
{
char pcdType(std::uint8_t datatype)
{
  switch (datatype)
  {
  case pcl::PCLPointField::FLOAT32:
  case pcl::PCLPointField::FLOAT64: return 'F';
  case pcl::PCLPointField::INT8:
  case pcl::PCLPointField::INT16:
  case pcl::PCLPointField::INT32:
  case pcl::PCLPointField::INT64: return 'I';
  default: return 'U';
  }
}

/// One value as ascii PCD text: integers exactly, float with 9 and double with 17 significant
/// digits (both read back to the same bits), a packed float `rgb` as its unsigned bits (as PCL
/// writes it: opaque colours are NaN as floats).
void asciiValue(std::ostream& out, const pcl::PCLPointField& f, const std::uint8_t* src)
{
  char buf[40];
  if (f.datatype == pcl::PCLPointField::FLOAT32 && f.name == "rgb")
  {
    std::uint32_t bits = 0;
    std::memcpy(&bits, src, 4);
    std::snprintf(buf, sizeof buf, "%" PRIu32, bits);
  }
  else if (f.datatype == pcl::PCLPointField::FLOAT32 || f.datatype == pcl::PCLPointField::FLOAT64)
  {
    const double v = detail::loadValue(f.datatype, src);
    if (std::isnan(v))
      std::snprintf(buf, sizeof buf, "nan");
    else
      std::snprintf(buf, sizeof buf, f.datatype == pcl::PCLPointField::FLOAT32 ? "%.9g" : "%.17g", v);
  }
  else if (f.datatype == pcl::PCLPointField::UINT64)
  {
    std::uint64_t v = 0;
    std::memcpy(&v, src, 8);
    std::snprintf(buf, sizeof buf, "%" PRIu64, v);
  }
  else if (f.datatype == pcl::PCLPointField::INT64)
  {
    std::int64_t v = 0;
    std::memcpy(&v, src, 8);
    std::snprintf(buf, sizeof buf, "%" PRId64, v);
  }
  else
    std::snprintf(buf, sizeof buf, "%.0f", detail::loadValue(f.datatype, src));
  out << buf;
}
}  // namespace

std::string pcdHeader(const std::vector<pcl::PCLPointField>& fields, std::uint64_t width, std::uint64_t height,
                      const std::array<double, 7>& viewpoint, const char* data, bool fixed_width_counts)
{
  std::ostringstream h;
  h << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS";
  for (const auto& f : fields)
    h << ' ' << f.name;
  h << "\nSIZE";
  for (const auto& f : fields)
    h << ' ' << detail::datatypeSize(f.datatype);
  h << "\nTYPE";
  for (const auto& f : fields)  // a packed float colour is declared U, as PCL declares it
    h << ' ' << (f.name == "rgb" && f.datatype == pcl::PCLPointField::FLOAT32 ? 'U' : pcdType(f.datatype));
  h << "\nCOUNT";
  for (const auto& f : fields)
    h << ' ' << f.count;
  // Fixed-width counts can be rewritten in place once the number of points is known.
  const int w = fixed_width_counts ? 20 : 0;
  h << "\nWIDTH " << std::left << std::setw(w) << width << "\nHEIGHT " << std::setw(w) << height << "\nVIEWPOINT";
  h << std::setprecision(17);
  for (const double v : viewpoint)
    h << ' ' << v;
  h << "\nPOINTS " << std::setw(w) << width * height << "\nDATA " << data << "\n";
  return h.str();
}

void writePcd(std::ostream& out, const pcl::PCLPointCloud2& input, Encoding encoding)
{
  const pcl::PCLPointCloud2 cloud = packedCloud(input);
  const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
  const std::array<double, 7> viewpoint{{0, 0, 0, 1, 0, 0, 0}};
  const char* data = encoding == Encoding::Ascii ? "ascii" : encoding == Encoding::Binary ? "binary" : "binary_compressed";
  out << pcdHeader(cloud.fields, cloud.width, cloud.height, viewpoint, data, false);
  if (encoding == Encoding::Binary)
  {
    out.write(reinterpret_cast<const char*>(cloud.data.data()), static_cast<std::streamsize>(cloud.data.size()));
    return;
  }
  if (encoding == Encoding::Ascii)
  {
    for (std::size_t i = 0; i < n; ++i)
    {
      const std::uint8_t* rec = cloud.data.data() + i * cloud.point_step;
      bool first = true;
      for (const auto& f : cloud.fields)
        for (std::uint32_t c = 0; c < f.count; ++c)
        {
          if (!first)
            out << ' ';
          first = false;
          asciiValue(out, f, rec + f.offset + c * detail::datatypeSize(f.datatype));
        }
      out << '\n';
    }
    return;
  }
  // binary_compressed: every field's values for all points in turn (structure of arrays), LZF
  // compressed, after the compressed and the uncompressed size (uint32 each).
  const std::size_t raw_size = cloud.data.size();
  if (raw_size > 0xFFFFFFFFull / 2)
    throw FileError("binary_compressed PCD holds at most 2 GiB of point data; write binary instead");
  std::vector<std::uint8_t> soa(raw_size);
  std::size_t at = 0;
  for (const auto& f : cloud.fields)
  {
    const std::size_t bytes = detail::datatypeSize(f.datatype) * f.count;
    for (std::size_t i = 0; i < n; ++i, at += bytes)
      std::memcpy(soa.data() + at, cloud.data.data() + i * cloud.point_step + f.offset, bytes);
  }
  std::vector<std::uint8_t> packed(raw_size + raw_size / 16 + 64);
  std::uint32_t sizes[2] = {0, static_cast<std::uint32_t>(raw_size)};
  if (raw_size > 0)
  {
    sizes[0] = pcl::lzfCompress(soa.data(), sizes[1], packed.data(), static_cast<unsigned>(packed.size()));
    if (sizes[0] == 0)
      throw FileError("LZF compression failed");
  }
  out.write(reinterpret_cast<const char*>(sizes), sizeof sizes);
  out.write(reinterpret_cast<const char*>(packed.data()), sizes[0]);
}

}  // namespace io
}  // namespace pcl_ecs
