// Our PCD parser: header checked field by field, data checked against the header's promises.
#include "io_detail.h"

#include <pcl_ecs/io/pcd_stream.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <limits>
#include <map>

#include <pcl/io/lzf.h>

namespace pcl_ecs
{
namespace io
{

using detail::fail;

namespace
{
std::vector<std::string> splitWords(const std::string& line)
{
  std::vector<std::string> words;
  std::size_t i = 0;
  while (i < line.size())
  {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i])))
      ++i;
    std::size_t j = i;
    while (j < line.size() && !std::isspace(static_cast<unsigned char>(line[j])))
      ++j;
    if (j > i)
      words.push_back(line.substr(i, j - i));
    i = j;
  }
  return words;
}

bool parseUnsigned(const std::string& s, std::uint64_t& v)
{
  if (s.empty() || s.size() > 19 || !std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }))
    return false;
  v = std::stoull(s);
  return true;
}

std::uint8_t pcdDatatype(char type, std::uint64_t size)
{
  switch (type)
  {
  case 'I':
    return size == 1 ? pcl::PCLPointField::INT8 : size == 2 ? pcl::PCLPointField::INT16
                                                   : size == 4 ? pcl::PCLPointField::INT32
                                                   : size == 8 ? pcl::PCLPointField::INT64 : 0;
  case 'U':
    return size == 1 ? pcl::PCLPointField::UINT8 : size == 2 ? pcl::PCLPointField::UINT16
                                                    : size == 4 ? pcl::PCLPointField::UINT32
                                                    : size == 8 ? pcl::PCLPointField::UINT64 : 0;
  case 'F':
    return size == 4 ? pcl::PCLPointField::FLOAT32 : size == 8 ? pcl::PCLPointField::FLOAT64 : 0;
  default: return 0;
  }
}

/// Largest point count we accept: PCL indexes points with 32-bit ints.
constexpr std::uint64_t kMaxPoints = static_cast<std::uint64_t>(std::numeric_limits<std::int32_t>::max());
}  // namespace

namespace
{
/// The header's keyword lines as read, before they are checked against each other.
struct RawPcdHeader
{
  std::vector<std::string> names, types;
  std::vector<std::uint64_t> sizes, counts;
  std::uint64_t width = 0, height = 1, points = 0;
  bool have_width = false, have_points = false, have_fields = false, have_height = false;
  std::string data;  ///< the DATA line's encoding: the last line of the header
};

/// One header line `key args...` (line number line_no) into `raw` (VIEWPOINT into `header`).
void readPcdKeyword(const std::string& key, const std::vector<std::string>& args, int line_no, RawPcdHeader& raw,
                    PcdHeader& header)
{
  auto needOne = [&]() -> std::uint64_t {
    std::uint64_t v = 0;
    if (args.size() != 1 || !parseUnsigned(args[0], v))
      fail("header line ", line_no, ": ", detail::quote(key), " needs one non-negative integer");
    return v;
  };
  if (key == "FIELDS" || key == "COLUMNS")
  {
    if (args.empty())
      fail("header line ", line_no, ": FIELDS lists no field");
    raw.names = args;
    raw.have_fields = true;
  }
  else if (key == "SIZE" || key == "COUNT")
  {
    std::vector<std::uint64_t>& dst = key == "SIZE" ? raw.sizes : raw.counts;
    dst.clear();
    for (const auto& a : args)
    {
      std::uint64_t v = 0;
      if (!parseUnsigned(a, v) || v == 0 || v > 1u << 20)
        fail("header line ", line_no, ": bad ", detail::quote(key), " value '", detail::quote(a), "'");
      dst.push_back(v);
    }
  }
  else if (key == "TYPE")
  {
    raw.types = args;
  }
  else if (key == "WIDTH")
  {
    raw.width = needOne();
    raw.have_width = true;
  }
  else if (key == "HEIGHT")
  {
    raw.height = needOne();
    raw.have_height = true;
  }
  else if (key == "POINTS")
  {
    raw.points = needOne();
    raw.have_points = true;
  }
  else if (key == "VIEWPOINT")
  {
    if (args.size() != 7)
      fail("header line ", line_no, ": VIEWPOINT needs 7 numbers");
    for (std::size_t i = 0; i < 7; ++i)
      if (!detail::parseNumber(args[i], header.viewpoint[i]))
        fail("header line ", line_no, ": bad VIEWPOINT value '", detail::quote(args[i]), "'");
  }
  else if (key == "DATA")
  {
    if (args.size() != 1 || (args[0] != "ascii" && args[0] != "binary" && args[0] != "binary_compressed"))
      fail("header line ", line_no, ": DATA must be ascii, binary or binary_compressed");
    raw.data = args[0];
  }
  else
  {
    fail("header line ", line_no, ": unknown keyword '", detail::quote(key), "': not a PCD header");
  }
}
}  // namespace

PcdHeader parsePcdHeader(const std::function<bool(std::string&)>& next_line, std::uint64_t max_points)
{
  RawPcdHeader raw;
  int line_no = 0;
  PcdHeader header;
  std::string line;
  while (raw.data.empty())
  {
    if (!next_line(line))
      fail("the header ends before its DATA line (", line_no, " lines read)");
    ++line_no;
    if (line_no > 1000)
      fail("no DATA line in the first 1000 lines: not a PCD file");
    if (line.size() > detail::kMaxHeaderLine)
      fail("header line ", line_no, " is longer than ", detail::kMaxHeaderLine / 1024, " KiB: not a PCD header");
    if (!line.empty() && line.back() == '\r')
      line.pop_back();
    const auto words = splitWords(line);
    if (words.empty() || words[0][0] == '#' || words[0] == "VERSION")
      continue;
    readPcdKeyword(words[0], std::vector<std::string>(words.begin() + 1, words.end()), line_no, raw, header);
  }
  std::vector<std::string>& names = raw.names;
  std::vector<std::string>& types = raw.types;
  std::vector<std::uint64_t>& sizes = raw.sizes;
  std::vector<std::uint64_t>& counts = raw.counts;
  std::uint64_t width = raw.width, height = raw.height, points = raw.points;
  const bool have_width = raw.have_width, have_points = raw.have_points, have_fields = raw.have_fields,
             have_height = raw.have_height;
  const std::string& data = raw.data;

  // The header must be complete and consistent.
  if (!have_fields)
    fail("the header has no FIELDS line");
  if (!have_width && !have_points)
    fail("the header has neither WIDTH nor POINTS");
  if (counts.empty())
    counts.assign(names.size(), 1);
  if (sizes.size() != names.size() || types.size() != names.size() || counts.size() != names.size())
    fail("the header is inconsistent: ", names.size(), " FIELDS, ", sizes.size(), " SIZE, ",
         types.size(), " TYPE and ", counts.size(), " COUNT entries");
  if (!have_width)
    width = points;
  if (!have_points)
    points = width * height;
  if (!have_height)
    height = 1;
  if (width > max_points || height > max_points || width * height != points)
    fail("the header is inconsistent: WIDTH ", width, " x HEIGHT ", height, " != POINTS ", points);
  if (points > max_points)
    fail("POINTS ", points, " is more than this reader supports");

  pcl::PCLPointCloud2 layout;
  for (std::size_t f = 0; f < names.size(); ++f)
  {
    if (types[f].size() != 1)
      fail("the header is inconsistent: TYPE '", detail::quote(types[f]), "' of field ", detail::quote(names[f]));
    const std::uint8_t dt = pcdDatatype(types[f][0], sizes[f]);
    if (dt == 0)
      fail("the header is inconsistent: field ", detail::quote(names[f]), " has TYPE ", detail::quote(types[f]), " with SIZE ", sizes[f]);
    if (counts[f] > 4096)
      fail("field ", detail::quote(names[f]), " has COUNT ", counts[f], ", more than this reader supports");
    for (std::size_t g = 0; g < f; ++g)
      if (names[g] == names[f] && names[f] != "_")
        fail("the header is inconsistent: field ", detail::quote(names[f]), " appears twice");
    detail::addField(layout, names[f], dt, static_cast<std::uint32_t>(counts[f]));
    if (layout.point_step > (1u << 20))
      fail("points of more than 1 MiB each are not supported");
  }
  if (layout.point_step == 0)
    fail("the header describes points of zero bytes");
  header.fields = layout.fields;
  header.point_step = layout.point_step;
  header.width = width;
  header.height = height;
  header.points = points;
  header.data = data == "ascii" ? PcdData::Ascii : data == "binary" ? PcdData::Binary : PcdData::BinaryCompressed;
  return header;
}

int PcdHeader::fieldIndex(const std::string& name) const
{
  for (std::size_t f = 0; f < fields.size(); ++f)
    if (fields[f].name == name)
      return static_cast<int>(f);
  return -1;
}

void parsePcd(const std::string& bytes, pcl::PCLPointCloud2& cloud)
{
  cloud = pcl::PCLPointCloud2{};
  if (bytes.empty())
    fail("the file is empty");
  std::size_t pos = 0;
  int line_no = 0;
  const PcdHeader header = parsePcdHeader(
      [&](std::string& line) {
        if (pos >= bytes.size())
          return false;
        ++line_no;
        std::size_t eol = bytes.find('\n', pos);
        if (eol == std::string::npos)
          eol = bytes.size();
        // An over-long line is cut (the parser refuses it) rather than copied whole.
        line.assign(bytes, pos, std::min(eol - pos, detail::kMaxHeaderLine + 1));
        pos = eol + 1;
        return true;
      },
      kMaxPoints);
  const std::uint64_t points = header.points;
  const std::string data = header.data == PcdData::Ascii ? "ascii" : header.data == PcdData::Binary ? "binary" : "binary_compressed";
  cloud.fields = header.fields;
  cloud.point_step = header.point_step;
  cloud.width = static_cast<std::uint32_t>(header.width);
  cloud.height = static_cast<std::uint32_t>(header.height);
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.is_bigendian = false;
  const std::uint64_t step = cloud.point_step;
  const std::uint64_t total = step * points;
  const std::uint64_t remaining = pos <= bytes.size() ? bytes.size() - pos : 0;

  if (data == "binary")
  {
    if (total > remaining)
      fail("truncated: the header promises ", points, " points (", total, " bytes) but the file holds ",
           remaining, " data bytes");
    cloud.data.assign(bytes.begin() + static_cast<std::ptrdiff_t>(pos),
                      bytes.begin() + static_cast<std::ptrdiff_t>(pos + total));
  }
  else if (data == "binary_compressed")
  {
    if (remaining < 8)
      fail("truncated: binary_compressed data without its sizes");
    std::uint32_t csize = 0, usize = 0;
    std::memcpy(&csize, bytes.data() + pos, 4);
    std::memcpy(&usize, bytes.data() + pos + 4, 4);
    if (csize > remaining - 8)
      fail("truncated: the compressed block is ", csize, " bytes but the file holds ", remaining - 8);
    if (usize != total)
      fail("the header is inconsistent: ", points, " points of ", step, " bytes need ", total,
           " bytes but the compressed block says ", usize);
    // LZF expands at most ~88×: refuse claims no compressed block could make (and huge allocations).
    if (total > 100ull * csize + 1024ull)
      fail("corrupt compressed block: ", csize, " bytes cannot hold ", total, " bytes");
    std::vector<std::uint8_t> unpacked(total);
    if (total > 0)
    {
      const unsigned got = pcl::lzfDecompress(bytes.data() + pos + 8, csize, unpacked.data(),
                                              static_cast<unsigned>(total));
      if (got != total)
        fail("corrupt compressed block: it unpacks to ", got, " bytes instead of ", total);
    }
    // The block holds each field for all points in turn; interleave into points.
    cloud.data.resize(total);
    std::uint64_t src = 0;
    for (const auto& f : cloud.fields)
    {
      const std::uint64_t fsize = detail::datatypeSize(f.datatype) * f.count;
      for (std::uint64_t i = 0; i < points; ++i, src += fsize)
        std::memcpy(cloud.data.data() + i * step + f.offset, unpacked.data() + src, fsize);
    }
  }
  else  // ascii
  {
    std::uint64_t values_per_point = 0;
    for (const auto& f : cloud.fields)
      values_per_point += f.count;
    if (points * values_per_point > remaining)
      fail("truncated: the header promises ", points, " points but the file is too short for them");
    cloud.data.assign(total, 0);
    std::size_t p = pos;
    std::uint64_t point = 0;
    int data_line = line_no;
    std::string token;
    auto nextToken = [&]() -> bool {
      while (p < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[p])))
      {
        if (bytes[p] == '\n')
          ++data_line;
        ++p;
      }
      const std::size_t b = p;
      while (p < bytes.size() && !std::isspace(static_cast<unsigned char>(bytes[p])))
        ++p;
      token.assign(bytes, b, p - b);
      return p > b;
    };
    for (; point < points; ++point)
    {
      std::uint8_t* dst = cloud.data.data() + point * step;
      for (const auto& f : cloud.fields)
        for (std::uint32_t c = 0; c < f.count; ++c)
        {
          if (!nextToken())
            fail("truncated: the header promises ", points, " points but the data ends after ", point);
          if (!detail::storeAsciiValue(token, f, dst + f.offset + c * detail::datatypeSize(f.datatype)))
            fail("line ", data_line + 1, ": '", detail::quote(token), "' is not a number (field ", detail::quote(f.name), ")");
        }
    }
    if (nextToken())
      fail("line ", data_line + 1, ": more data than the header's ", points, " points");
  }
  detail::setDenseFlag(cloud);
}

}  // namespace io
}  // namespace pcl_ecs
