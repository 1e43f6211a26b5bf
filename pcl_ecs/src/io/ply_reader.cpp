// Our PLY parser: the vertex element of ascii and binary (little / big endian) files.
#include "io_detail.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>

namespace pcl_ecs
{
namespace io
{

using detail::fail;

namespace
{
struct Property
{
  std::string name;
  std::uint8_t type = 0;        // PCLPointField datatype of the value
  std::uint8_t count_type = 0;  // non-zero for a list: datatype of its length
};

struct Element
{
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
};

std::uint8_t plyType(const std::string& t)
{
  if (t == "char" || t == "int8") return pcl::PCLPointField::INT8;
  if (t == "uchar" || t == "uint8") return pcl::PCLPointField::UINT8;
  if (t == "short" || t == "int16") return pcl::PCLPointField::INT16;
  if (t == "ushort" || t == "uint16") return pcl::PCLPointField::UINT16;
  if (t == "int" || t == "int32") return pcl::PCLPointField::INT32;
  if (t == "uint" || t == "uint32") return pcl::PCLPointField::UINT32;
  if (t == "float" || t == "float32") return pcl::PCLPointField::FLOAT32;
  if (t == "double" || t == "float64") return pcl::PCLPointField::FLOAT64;
  return 0;
}

std::vector<std::string> words(const std::string& line)
{
  std::vector<std::string> w;
  std::string cur;
  for (char c : line)
  {
    if (std::isspace(static_cast<unsigned char>(c)))
    {
      if (!cur.empty())
        w.push_back(cur);
      cur.clear();
    }
    else
      cur += c;
  }
  if (!cur.empty())
    w.push_back(cur);
  return w;
}

/// Reads values from the body, in the file's encoding.
class BodyReader
{
public:
  BodyReader(const std::string& bytes, std::size_t pos, int encoding)
    : bytes_(bytes), pos_(pos), encoding_(encoding)
  {
  }

  double next(std::uint8_t type, const char* what)
  {
    if (encoding_ == 0)
    {
      while (pos_ < bytes_.size() && std::isspace(static_cast<unsigned char>(bytes_[pos_])))
        ++pos_;
      const std::size_t b = pos_;
      while (pos_ < bytes_.size() && !std::isspace(static_cast<unsigned char>(bytes_[pos_])))
        ++pos_;
      if (pos_ == b)
        fail("truncated: the data ends inside ", what);
      double v = 0.0;
      const std::string token = bytes_.substr(b, pos_ - b);
      if (!detail::parseNumber(token, v))
        fail("'", detail::quote(token), "' in ", what, " is not a number");
      return v;
    }
    const std::size_t size = detail::datatypeSize(type);
    if (pos_ + size > bytes_.size())
      fail("truncated: the data ends inside ", what);
    std::uint8_t buf[8];
    std::memcpy(buf, bytes_.data() + pos_, size);
    if (encoding_ == 2)
      std::reverse(buf, buf + size);
    pos_ += size;
    return detail::loadValue(type, buf);
  }

  std::size_t remaining() const { return pos_ < bytes_.size() ? bytes_.size() - pos_ : 0; }

private:
  const std::string& bytes_;
  std::size_t pos_;
  int encoding_;  // 0 ascii, 1 little endian, 2 big endian
};

/// The PCL field a PLY vertex property maps to; empty to skip it.
std::string pclName(const std::string& p)
{
  static const std::map<std::string, std::string> names = {
      {"x", "x"}, {"y", "y"}, {"z", "z"},
      {"nx", "normal_x"}, {"ny", "normal_y"}, {"nz", "normal_z"},
      {"normal_x", "normal_x"}, {"normal_y", "normal_y"}, {"normal_z", "normal_z"},
      {"intensity", "intensity"}, {"scalar_intensity", "intensity"}, {"scalar_Intensity", "intensity"},
      {"label", "label"}, {"curvature", "curvature"}, {"ecs_label", "ecs_label"}};
  const auto it = names.find(p);
  if (it != names.end())
    return it->second;
  // Any other property travels through under its own name; CloudCompare's scalar fields are
  // written as scalar_NAME (and writePly writes ours so).
  if (p.rfind("scalar_", 0) == 0 && p.size() > 7)
    return p.substr(7);
  return p;
}

int colourChannel(const std::string& p)
{
  if (p == "red" || p == "r" || p == "diffuse_red") return 0;
  if (p == "green" || p == "g" || p == "diffuse_green") return 1;
  if (p == "blue" || p == "b" || p == "diffuse_blue") return 2;
  if (p == "alpha" || p == "a" || p == "diffuse_alpha") return 3;
  return -1;
}

/// What a PLY header declares.
struct PlyHeader
{
  int encoding = -1;  // 0 ascii, 1 little endian, 2 big endian
  std::vector<Element> elements;
  std::size_t body = 0;  // where the body starts
  std::vector<Element>::const_iterator vertex() const
  {
    return std::find_if(elements.begin(), elements.end(), [](const Element& e) { return e.name == "vertex"; });
  }
  /// The fewest body bytes the elements up to the vertices need: a value takes at least one byte
  /// in ascii (plus a separator) and its size in binary; a list at least its length.
  std::uint64_t leastBodyBytes() const
  {
    std::uint64_t total = 0;
    for (auto e = elements.begin(); e != elements.end(); ++e)
    {
      std::uint64_t record = 0;
      for (const auto& q : e->properties)
        record += encoding == 0 ? 1 : detail::datatypeSize(q.count_type ? q.count_type : q.type);
      total += record * e->count;
      if (e == vertex())
        break;
    }
    return total;
  }
};

/// Parse the header held at the start of `bytes` (it must hold all of it).
PlyHeader parsePlyHeader(const std::string& bytes)
{
  if (bytes.empty())
    fail("the file is empty");
  if (bytes.compare(0, 3, "ply") != 0 || bytes.size() < 4 || (bytes[3] != '\n' && bytes[3] != '\r'))
    fail("it does not start with 'ply': not a PLY file");
  PlyHeader h;
  std::size_t pos = 0;
  int& encoding = h.encoding;
  std::vector<Element>& elements = h.elements;
  int line_no = 0;
  for (;;)
  {
    if (pos >= bytes.size())
      fail("the header has no end_header line");
    std::size_t eol = bytes.find('\n', pos);
    if (eol == std::string::npos)
      fail("the header has no end_header line");
    std::string line = bytes.substr(pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    if (line_no > 10000)
      fail("the header is longer than 10000 lines");
    if (!line.empty() && line.back() == '\r')
      line.pop_back();
    const auto w = words(line);
    if (w.empty() || w[0] == "comment" || w[0] == "obj_info" || w[0] == "ply")
      continue;
    if (w[0] == "end_header")
      break;
    if (w[0] == "format")
    {
      if (w.size() != 3 || w[2] != "1.0")
        fail("header line ", line_no, ": bad format line");
      encoding = w[1] == "ascii" ? 0 : w[1] == "binary_little_endian" ? 1 : w[1] == "binary_big_endian" ? 2 : -1;
      if (encoding < 0)
        fail("header line ", line_no, ": unknown format '", detail::quote(w[1]), "'");
    }
    else if (w[0] == "element")
    {
      std::uint64_t count = 0;
      double v = 0.0;
      if (w.size() != 3 || !detail::parseNumber(w[2], v) || v < 0 || v != std::floor(v) || v > 2147483647.0)
        fail("header line ", line_no, ": bad element line");
      count = static_cast<std::uint64_t>(v);
      elements.push_back({w[1], count, {}});
    }
    else if (w[0] == "property")
    {
      if (elements.empty())
        fail("header line ", line_no, ": property before any element");
      Property prop;
      if (w.size() == 5 && w[1] == "list")
      {
        prop.count_type = plyType(w[2]);
        prop.type = plyType(w[3]);
        prop.name = w[4];
        if (!prop.count_type || !prop.type || prop.count_type == pcl::PCLPointField::FLOAT32 ||
            prop.count_type == pcl::PCLPointField::FLOAT64)
          fail("header line ", line_no, ": bad list property");
      }
      else if (w.size() == 3)
      {
        prop.type = plyType(w[1]);
        prop.name = w[2];
        if (!prop.type)
          fail("header line ", line_no, ": unknown property type '", detail::quote(w[1]), "'");
      }
      else
        fail("header line ", line_no, ": bad property line");
      elements.back().properties.push_back(prop);
    }
    else
      fail("header line ", line_no, ": unknown keyword '", detail::quote(w[0]), "'");
  }
  if (encoding < 0)
    fail("the header has no format line");
  if (h.vertex() == elements.end() || h.vertex()->count == 0)
    fail("it has no vertices (no 'element vertex' or a count of 0)");
  h.body = pos;
  return h;
}
}  // namespace

namespace
{
/// Reads past the elements before `vertex_it` (checking that a fixed-size binary element fits
/// before looping over its count).
void skipElementsBefore(const std::vector<Element>& elements, std::vector<Element>::const_iterator vertex_it,
                        int encoding, BodyReader& body)
{
  for (auto e = elements.begin(); e != vertex_it; ++e)
  {
    // Binary elements without lists have a fixed size: check before looping over a huge count.
    if (encoding != 0 && std::none_of(e->properties.begin(), e->properties.end(), [](const Property& q) { return q.count_type != 0; }))
    {
      std::uint64_t rec = 0;
      for (const auto& q : e->properties)
        rec += detail::datatypeSize(q.type);
      if (rec * e->count > body.remaining())
        fail("truncated: element ", e->name, " needs more bytes than the file holds");
    }
    for (std::uint64_t i = 0; i < e->count; ++i)
      for (const auto& q : e->properties)
      {
        const double n = q.count_type ? body.next(q.count_type, "a list length") : 1.0;
        if (n < 0 || n > 1e6)
          fail("element ", e->name, " has a list of ", n, " entries");
        for (std::uint64_t k = 0; k < static_cast<std::uint64_t>(n); ++k)
          body.next(q.type, "an element before the vertices");
      }
  }
}
}  // namespace

void parsePly(const std::string& bytes, pcl::PCLPointCloud2& cloud)
{
  cloud = pcl::PCLPointCloud2{};
  const PlyHeader h = parsePlyHeader(bytes);
  const int encoding = h.encoding;
  const std::vector<Element>& elements = h.elements;
  const std::size_t pos = h.body;
  const auto vertex_it = h.vertex();
  const Element& vertex = *vertex_it;
  if (h.leastBodyBytes() > bytes.size() - pos)
    fail("truncated: ", vertex.count, " vertices need more bytes than the file holds");

  // Fields of the cloud, from the vertex properties.
  std::vector<int> field_of(vertex.properties.size(), -1);
  std::vector<int> channel_of(vertex.properties.size(), -1);
  bool has_colour = false, has_alpha = false;
  for (std::size_t p = 0; p < vertex.properties.size(); ++p)
  {
    const Property& prop = vertex.properties[p];
    if (prop.count_type)
      continue;
    const int ch = colourChannel(prop.name);
    if (ch >= 0)
    {
      channel_of[p] = ch;
      has_colour = has_colour || ch < 3;
      has_alpha = has_alpha || ch == 3;
      continue;
    }
    const std::string name = pclName(prop.name);
    if (name.empty())
      continue;
    for (const auto& f : cloud.fields)
      if (f.name == name)
        fail("the vertex element has the property ", prop.name, " twice");
    // Every property keeps its type: double coordinates stay double, integer fields integers.
    detail::addField(cloud, name, prop.type);
    field_of[p] = static_cast<int>(cloud.fields.size() - 1);
  }
  for (const char* axis : {"x", "y", "z"})
    if (std::none_of(cloud.fields.begin(), cloud.fields.end(), [&](const pcl::PCLPointField& f) { return f.name == axis; }))
      fail("the vertex element has no '", axis, "' property");
  std::uint32_t rgb_offset = 0;
  // The colour channels become one packed field: a property of that name as well is ambiguous.
  if (has_colour && std::any_of(cloud.fields.begin(), cloud.fields.end(), [&](const pcl::PCLPointField& f) {
        return f.name == (has_alpha ? "rgba" : "rgb");
      }))
    fail("the vertex element has colour channels and a property ", has_alpha ? "rgba" : "rgb", " as well");
  if (has_colour)
    rgb_offset = detail::addField(cloud, has_alpha ? "rgba" : "rgb",
                                  has_alpha ? pcl::PCLPointField::UINT32 : pcl::PCLPointField::FLOAT32);

  // Skip the elements before the vertices, then read them.
  BodyReader body(bytes, pos, encoding);
  skipElementsBefore(elements, vertex_it, encoding, body);
  // Each value takes at least one byte in ascii (plus a separator) and its size in binary.
  std::uint64_t record = 0;
  for (const auto& q : vertex.properties)
    record += (q.count_type || encoding == 0) ? 1 : detail::datatypeSize(q.type);
  if (record * vertex.count > body.remaining())
    fail("truncated: ", vertex.count, " vertices need more bytes than the file holds");
  cloud.width = static_cast<std::uint32_t>(vertex.count);
  cloud.height = 1;
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.data.assign(static_cast<std::size_t>(cloud.point_step) * vertex.count, 0);
  for (std::uint64_t i = 0; i < vertex.count; ++i)
  {
    std::uint8_t* dst = cloud.data.data() + i * cloud.point_step;
    std::uint8_t rgba[4] = {0, 0, 0, 255};
    for (std::size_t p = 0; p < vertex.properties.size(); ++p)
    {
      const Property& prop = vertex.properties[p];
      if (prop.count_type)
      {
        const double n = body.next(prop.count_type, "a vertex list length");
        if (n < 0 || n > 1e6)
          fail("vertex ", i, " has a list of ", n, " entries");
        for (std::uint64_t k = 0; k < static_cast<std::uint64_t>(n); ++k)
          body.next(prop.type, "a vertex");
        continue;
      }
      const double v = body.next(prop.type, "a vertex");
      if (field_of[p] >= 0)
      {
        const auto& f = cloud.fields[static_cast<std::size_t>(field_of[p])];
        detail::storeValue(v, f.datatype, dst + f.offset);
      }
      else if (channel_of[p] >= 0)
      {
        // Float colours in [0, 1] are scaled to bytes.
        const bool unit = prop.type == pcl::PCLPointField::FLOAT32 || prop.type == pcl::PCLPointField::FLOAT64;
        const double byte = unit ? v * 255.0 : v;
        rgba[channel_of[p]] = static_cast<std::uint8_t>(std::min(255.0, std::max(0.0, std::round(std::isfinite(byte) ? byte : 0.0))));
      }
    }
    if (has_colour)
    {
      // PCL's packing: b | g << 8 | r << 16 | a << 24.
      const std::uint32_t packed = static_cast<std::uint32_t>(rgba[2]) | (static_cast<std::uint32_t>(rgba[1]) << 8) |
                                   (static_cast<std::uint32_t>(rgba[0]) << 16) | (static_cast<std::uint32_t>(rgba[3]) << 24);
      std::memcpy(dst + rgb_offset, &packed, 4);
    }
  }
  detail::setDenseFlag(cloud);
}

CloudProbe probePly(std::istream& in, std::uint64_t file_size)
{
  // The header's lines only (at most 10000 of at most kMaxHeaderLine bytes each), never the body.
  std::string header, line;
  for (int n = 0; n < 10001 && detail::readHeaderLine(in, line); ++n)
  {
    if (line.size() > detail::kMaxHeaderLine)
      fail("header line ", n + 1, " is longer than ", detail::kMaxHeaderLine / 1024, " KiB: not a PLY header");
    header += line;
    header += '\n';
    if (words(line) == std::vector<std::string>{"end_header"})
      break;
  }
  const PlyHeader h = parsePlyHeader(header);
  const Element& vertex = *h.vertex();
  if (h.body > file_size || h.leastBodyBytes() > file_size - h.body)
    fail("truncated: ", vertex.count, " vertices need more bytes than the file holds");
  CloudProbe probe;
  probe.points = vertex.count;
  for (const auto& q : vertex.properties)
    probe.point_step += q.count_type ? 0 : detail::datatypeSize(q.type);
  return probe;
}

}  // namespace io
}  // namespace pcl_ecs
