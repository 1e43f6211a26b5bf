// LAS / LAZ reading and writing (las_io.h). The header, the VLRs and the point records are ours
// (the layout is ASPRS LAS 1.4 R15's); LASzip compression is the laz crate's, through the C ABI of
// rust/ecs_laz.
#include "io_detail.h"
#include "las_detail.h"

#include <pcl_ecs/io/las_io.h>
#include <pcl_ecs/version.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <sstream>


namespace pcl_ecs
{
namespace io
{

namespace
{
using detail::fail;
using las::ReadAt;
using Field = pcl::PCLPointField;

constexpr std::size_t kHeader12 = 227, kHeader13 = 235, kHeader14 = 375, kVlrHeader = 54, kEvlrHeader = 60;
constexpr const char* kLaszipUser = "laszip encoded";
constexpr std::uint16_t kLaszipRecord = 22204;
// A LAZ file cannot expand beyond this many bytes of records per compressed byte: a header that
// claims more is refused before anything is allocated (real scans compress 5-20 times; a million
// copies of one point, about 2,800 times).
constexpr double kMaxLazRatio = 5000.0;

/// One dimension of a point record: `bits` bits from bit `shift` of the little-endian integer of
/// `size` bytes at `offset` (bits 0: the whole value, raw), kept as PCL `datatype`.
struct Dim
{
  const char* name;
  std::uint8_t datatype;
  std::uint16_t offset;
  std::uint8_t size;
  std::uint8_t shift;
  std::uint8_t bits;
};

std::vector<Dim> dimsOf(int format)
{
  static const Dim legacy[] = {{"intensity", Field::UINT16, 12, 2, 0, 16},
         {"return_number", Field::UINT8, 14, 1, 0, 3},
         {"number_of_returns", Field::UINT8, 14, 1, 3, 3},
         {"scan_direction_flag", Field::UINT8, 14, 1, 6, 1},
         {"edge_of_flight_line", Field::UINT8, 14, 1, 7, 1},
         {"classification", Field::UINT8, 15, 1, 0, 5},
         {"synthetic", Field::UINT8, 15, 1, 5, 1},
         {"key_point", Field::UINT8, 15, 1, 6, 1},
         {"withheld", Field::UINT8, 15, 1, 7, 1},
         {"scan_angle_rank", Field::INT8, 16, 1, 0, 0},
         {"user_data", Field::UINT8, 17, 1, 0, 8},
         {"point_source_id", Field::UINT16, 18, 2, 0, 16}};
  static const Dim extended[] = {{"intensity", Field::UINT16, 12, 2, 0, 16},
         {"return_number", Field::UINT8, 14, 1, 0, 4},
         {"number_of_returns", Field::UINT8, 14, 1, 4, 4},
         {"synthetic", Field::UINT8, 15, 1, 0, 1},
         {"key_point", Field::UINT8, 15, 1, 1, 1},
         {"withheld", Field::UINT8, 15, 1, 2, 1},
         {"overlap", Field::UINT8, 15, 1, 3, 1},
         {"scanner_channel", Field::UINT8, 15, 1, 4, 2},
         {"scan_direction_flag", Field::UINT8, 15, 1, 6, 1},
         {"edge_of_flight_line", Field::UINT8, 15, 1, 7, 1},
         {"classification", Field::UINT8, 16, 1, 0, 8},
         {"user_data", Field::UINT8, 17, 1, 0, 8},
         {"scan_angle", Field::INT16, 18, 2, 0, 0},
         {"point_source_id", Field::UINT16, 20, 2, 0, 16},
         {"gps_time", Field::FLOAT64, 22, 8, 0, 0}};
  const bool old = format <= 5;
  std::vector<Dim> d(old ? std::begin(legacy) : std::begin(extended), old ? std::end(legacy) : std::end(extended));
  std::uint16_t at = 30;
  if (old)
  {
    at = 20;
    if (format == 1 || format >= 3)
    {
      d.push_back({"gps_time", Field::FLOAT64, at, 8, 0, 0});
      at += 8;
    }
  }
  const bool colour = format == 2 || format == 3 || format == 5 || format == 7 || format == 8 || format == 10;
  if (colour)
  {
    for (const char* c : {"red", "green", "blue"})
    {
      d.push_back({c, Field::UINT16, at, 2, 0, 16});
      at += 2;
    }
  }
  if (format == 8 || format == 10)
  {
    d.push_back({"nir", Field::UINT16, at, 2, 0, 16});
    at += 2;
  }
  if (format == 4 || format == 5 || format == 9 || format == 10)
  {
    d.push_back({"wavepacket_index", Field::UINT8, at, 1, 0, 8});
    d.push_back({"wavepacket_offset", Field::UINT64, static_cast<std::uint16_t>(at + 1), 8, 0, 0});
    d.push_back({"wavepacket_size", Field::UINT32, static_cast<std::uint16_t>(at + 9), 4, 0, 32});
    const char* floats[] = {"return_point_wave_location", "x_t", "y_t", "z_t"};
    for (int k = 0; k < 4; ++k)
      d.push_back({floats[k], Field::FLOAT32, static_cast<std::uint16_t>(at + 13 + 4 * k), 4, 0, 0});
  }
  return d;
}

template <typename T>
T get(const std::uint8_t* p)
{
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}
template <typename T>
void put(std::uint8_t* p, T v)
{
  std::memcpy(p, &v, sizeof(T));
}
template <typename T>
T at(const std::string& bytes, std::size_t offset)
{
  return get<T>(reinterpret_cast<const std::uint8_t*>(bytes.data()) + offset);
}

std::uint64_t readUnsigned(const std::uint8_t* p, std::size_t size)
{
  std::uint64_t v = 0;
  for (std::size_t k = 0; k < size; ++k)
    v |= static_cast<std::uint64_t>(p[k]) << (8 * k);
  return v;
}
void writeUnsigned(std::uint8_t* p, std::size_t size, std::uint64_t v)
{
  for (std::size_t k = 0; k < size; ++k)
    p[k] = static_cast<std::uint8_t>(v >> (8 * k));
}

std::string fixedString(const std::string& bytes, std::size_t offset, std::size_t n)
{
  std::string s = bytes.substr(offset, n);
  const auto end = s.find('\0');
  return end == std::string::npos ? s : s.substr(0, end);
}

using HeaderView = las::Header;

HeaderView readHeader(const std::string& bytes, std::uint64_t file_size)
{
  if (bytes.size() < 4 || bytes.compare(0, 4, "LASF") != 0)
    fail("not a LAS file (it does not start with \"LASF\")");
  if (bytes.size() < kHeader12)
    fail("truncated: ", bytes.size(), " bytes, a LAS header has at least ", kHeader12);
  HeaderView h;
  const int major = static_cast<std::uint8_t>(bytes[24]);
  h.minor = static_cast<std::uint8_t>(bytes[25]);
  if (major != 1 || h.minor > 4)
    fail("LAS version ", major, ".", int{h.minor}, " is not one this reader knows (1.0 to 1.4)");
  h.header_size = at<std::uint16_t>(bytes, 94);
  const std::size_t needed = h.minor >= 4 ? kHeader14 : h.minor == 3 ? kHeader13 : kHeader12;
  if (h.header_size < needed)
    fail("its header size ", h.header_size, " is below the ", needed, " bytes of a LAS 1.", int{h.minor}, " header");
  if (bytes.size() < needed)
    fail("truncated: ", bytes.size(), " bytes, a LAS 1.", int{h.minor}, " header has ", needed);
  h.point_offset = at<std::uint32_t>(bytes, 96);
  h.vlr_count = at<std::uint32_t>(bytes, 100);
  const std::uint8_t fb = static_cast<std::uint8_t>(bytes[104]);
  h.compressed = (fb & 0x80) != 0;
  h.format = fb & 0x3F;
  h.record_length = at<std::uint16_t>(bytes, 105);
  if (h.format > 10)
    fail("point format ", h.format, " is not one of LAS 1.4's (0 to 10)");
  if (h.format > 5 && h.minor < 4)
    fail("point format ", h.format, " needs LAS 1.4; the header says 1.", int{h.minor});
  if (h.record_length < lasStandardRecordLength(h.format))
    fail("its record length ", h.record_length, " is shorter than point format ", h.format, "'s ",
         lasStandardRecordLength(h.format), " bytes");
  if (h.point_offset < h.header_size || h.point_offset > file_size)
    fail("its point data offset ", h.point_offset, " is outside the file (header ", h.header_size, " bytes, file ",
         file_size, ")");
  h.points = at<std::uint32_t>(bytes, 107);
  if (h.minor >= 4)
  {
    const std::uint64_t n14 = at<std::uint64_t>(bytes, 247);
    if (h.points != 0 && n14 != 0 && n14 != h.points)
      fail("its point counts disagree (", h.points, " in the legacy field, ", n14, " in the LAS 1.4 field)");
    h.points = std::max<std::uint64_t>(h.points, n14);
  }
  for (int a = 0; a < 3; ++a)
  {
    const double s = at<double>(bytes, 131 + 8 * a), o = at<double>(bytes, 155 + 8 * a);
    if (!std::isfinite(s) || s == 0.0 || !std::isfinite(o))
      fail("its ", "xyz"[a], " scale ", s, " or offset ", o, " is not usable");
  }
  const std::uint64_t body = file_size - h.point_offset;
  if (!h.compressed && h.points > body / h.record_length)
    fail("truncated: the header declares ", h.points, " points of ", h.record_length, " bytes from byte ",
         h.point_offset, " but the file holds ", body / h.record_length);
  if (h.compressed && static_cast<double>(h.points) * h.record_length > kMaxLazRatio * static_cast<double>(body) + 65536.0)
    fail("truncated: the header declares ", h.points, " points but its ", body,
         " bytes of compressed data cannot hold them");
  return h;
}


void readVlr(const ReadAt& read_at, std::uint64_t& pos, std::uint64_t end, bool extended, LasVlr& v)
{
  const std::size_t head = extended ? kEvlrHeader : kVlrHeader;
  const char* what = extended ? "an EVLR" : "a VLR";
  const char* past = extended ? "the end of the file" : "the point data";
  if (pos + head > end)
    fail(what, " at byte ", pos, " runs past ", past);
  const std::string h = read_at(pos, head);
  if (h.size() < head)
    fail(what, " at byte ", pos, " runs past the end of the file");
  v.reserved = at<std::uint16_t>(h, 0);
  v.user_id = fixedString(h, 2, 16);
  v.record_id = at<std::uint16_t>(h, 18);
  const std::uint64_t len = extended ? at<std::uint64_t>(h, 20) : at<std::uint16_t>(h, 20);
  v.description = fixedString(h, extended ? 28 : 22, 32);
  v.extended = extended;
  if (len > end - pos - head)
    fail(what, " at byte ", pos, " declares ", len, " bytes, past ", past);
  const std::string data = read_at(pos + head, static_cast<std::size_t>(len));
  if (data.size() < len)
    fail(what, " at byte ", pos, " runs past the end of the file");
  v.data.assign(data.begin(), data.end());
  pos += head + len;
}

void appendVlr(std::string& out, const LasVlr& v)
{
  std::uint8_t h[kEvlrHeader] = {};
  put<std::uint16_t>(h, v.reserved);
  std::memcpy(h + 2, v.user_id.data(), std::min<std::size_t>(16, v.user_id.size()));
  put<std::uint16_t>(h + 18, v.record_id);
  std::size_t head = kVlrHeader;
  if (v.extended)
  {
    put<std::uint64_t>(h + 20, v.data.size());
    std::memcpy(h + 28, v.description.data(), std::min<std::size_t>(32, v.description.size()));
    head = kEvlrHeader;
  }
  else
  {
    put<std::uint16_t>(h + 20, static_cast<std::uint16_t>(v.data.size()));
    std::memcpy(h + 22, v.description.data(), std::min<std::size_t>(32, v.description.size()));
  }
  out.append(reinterpret_cast<const char*>(h), head);
  out.append(reinterpret_cast<const char*>(v.data.data()), v.data.size());
}

bool isLaszip(const LasVlr& v) { return v.user_id == kLaszipUser && v.record_id == kLaszipRecord; }

#ifndef PCL_ECS_HAVE_LAZ
[[noreturn]] void noLaz()
{
  fail("LAZ is not supported by this build of pcl_ecs (built with -DPCL_ECS_WITH_LAZ=OFF: see docs/LAS.md)");
}
#endif
}  // namespace

std::size_t lasStandardRecordLength(int format)
{
  static const std::size_t len[] = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
  return format >= 0 && format <= 10 ? len[format] : 0;
}

bool lazSupported()
{
#ifdef PCL_ECS_HAVE_LAZ
  return true;
#else
  return false;
#endif
}

std::size_t lazMaxExtraBytes()
{
#ifdef PCL_ECS_HAVE_LAZ
  return static_cast<std::size_t>(ecs_laz_max_extra_bytes());
#else
  return 0;
#endif
}

std::string lazCannotWrite(const LasInfo& info)
{
  if (!lazSupported())
    return "this build has no LAZ support (built with -DPCL_ECS_WITH_LAZ=OFF)";
  const std::size_t standard = lasStandardRecordLength(info.point_format);
  const std::size_t extra = info.record_length > standard ? info.record_length - standard : 0;
  if (extra <= lazMaxExtraBytes())
    return {};
  std::ostringstream s;
  s << "these records have " << extra << " extra bytes and LAZ holds at most " << lazMaxExtraBytes()
    << " (the codec keeps up to 45 kB of models per extra byte): write LAS (uncompressed) instead";
  return s.str();
}

namespace las
{

namespace
{
constexpr const char* kSpecUser = "LASF_Spec";
constexpr std::uint16_t kExtraBytesRecord = 4;
constexpr std::size_t kExtraBytesDescriptor = 192;

/// LAS extra-byte data types 1-10 (u8 i8 u16 i16 u32 i32 u64 i64 f32 f64) as PCL datatypes.
std::uint8_t pclTypeOfLas(int las_type)
{
  static const std::uint8_t types[] = {Field::UINT8,  Field::INT8,   Field::UINT16, Field::INT16,   Field::UINT32,
                                       Field::INT32,  Field::UINT64, Field::INT64,  Field::FLOAT32, Field::FLOAT64};
  return las_type >= 1 && las_type <= 10 ? types[las_type - 1] : 0;
}

/// The LAS extra-byte data type of a PCL datatype (0 when there is none).
std::uint8_t lasTypeOfPcl(std::uint8_t datatype)
{
  for (int t = 1; t <= 10; ++t)
    if (pclTypeOfLas(t) == datatype)
      return static_cast<std::uint8_t>(t);
  return 0;
}

bool isExtraBytesVlr(const LasVlr& v)
{
  return v.user_id == kSpecUser && v.record_id == kExtraBytesRecord && !v.extended;
}

/// A 192-byte descriptor of the Extra Bytes VLR: `las_type` (0: `undocumented` bytes, counted in
/// the options byte), the name and a description, no no-data, min, max, scale or offset.
std::vector<std::uint8_t> descriptor(std::uint8_t las_type, std::size_t undocumented, const std::string& name,
                                     const std::string& description)
{
  std::vector<std::uint8_t> d(kExtraBytesDescriptor, 0);
  d[2] = las_type;
  d[3] = static_cast<std::uint8_t>(las_type == 0 ? undocumented : 0);
  std::memcpy(d.data() + 4, name.data(), std::min<std::size_t>(31, name.size()));
  std::memcpy(d.data() + 160, description.data(), std::min<std::size_t>(31, description.size()));
  return d;
}
}  // namespace

bool extraDims(const LasInfo& info, std::vector<ExtraDim>& dims, std::string& why)
{
  dims.clear();
  const auto vlr = std::find_if(info.vlrs.begin(), info.vlrs.end(), isExtraBytesVlr);
  if (vlr == info.vlrs.end())
    return true;
  const std::vector<std::uint8_t>& data = vlr->data;
  if (data.size() % kExtraBytesDescriptor != 0)
  {
    why = "its Extra Bytes VLR holds " + std::to_string(data.size()) + " bytes, not a whole number of 192-byte descriptors";
    return false;
  }
  std::size_t offset = 0;
  for (std::size_t at = 0; at < data.size(); at += kExtraBytesDescriptor)
  {
    const std::uint8_t* d = data.data() + at;
    ExtraDim e;
    e.las_type = d[2];
    const std::uint8_t options = d[3];
    e.name = std::string(reinterpret_cast<const char*>(d + 4), 32);
    e.name = e.name.substr(0, e.name.find('\0'));
    if (e.las_type == 0)
      e.size = options;  // undocumented extra bytes: the options byte counts them
    else if (e.las_type <= 30)
    {
      const int base = (e.las_type - 1) % 10 + 1, components = (e.las_type - 1) / 10 + 1;
      e.size = detail::datatypeSize(pclTypeOfLas(base)) * static_cast<std::size_t>(components);
      // A plain number: one component, neither scaled nor offset (options bits 3 and 4).
      if (components == 1 && (options & 0x18u) == 0)
        e.datatype = pclTypeOfLas(base);
    }
    else
    {
      why = "its Extra Bytes VLR describes \"" + detail::quote(e.name) + "\" with data type " +
            std::to_string(int{e.las_type}) + ", which LAS does not define";
      return false;
    }
    e.offset = offset;
    offset += e.size;
    dims.push_back(std::move(e));
  }
  return true;
}

std::vector<pcl::PCLPointField> cloudFields(int format, std::size_t extra, std::uint32_t& step)
{
  pcl::PCLPointCloud2 c;
  for (const char* a : {"x", "y", "z"})
    detail::addField(c, a, Field::FLOAT64);
  for (const Dim& d : dimsOf(format))
    detail::addField(c, d.name, d.datatype);
  if (extra > 0)
    detail::addField(c, "extra_bytes", Field::UINT8, static_cast<std::uint32_t>(extra));
  step = c.point_step;
  return c.fields;
}

std::vector<ExtraDim> namedExtraDims(const LasInfo& info, std::size_t extra)
{
  std::vector<ExtraDim> dims;
  std::string why;
  if (extra == 0 || !extraDims(info, dims, why))
    return {};
  std::size_t described = 0;
  for (std::size_t k = 0; k < dims.size(); ++k)
  {
    const ExtraDim& d = dims[k];
    const bool plain_name =
        !d.name.empty() && std::all_of(d.name.begin(), d.name.end(), [](char ch) {
          return (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '_';
        });
    if (d.datatype == 0 || !plain_name || isLasFieldName(d.name))
      return {};
    for (std::size_t j = 0; j < k; ++j)
      if (dims[j].name == d.name)
        return {};
    described += d.size;
  }
  return described == extra ? dims : std::vector<ExtraDim>();
}

std::vector<pcl::PCLPointField> cloudFields(const Layout& layout, std::uint32_t& step)
{
  const std::vector<ExtraDim> named = namedExtraDims(layout.info, layout.extra());
  if (named.empty())
    return cloudFields(layout.format, layout.extra(), step);
  pcl::PCLPointCloud2 c;
  c.fields = cloudFields(layout.format, 0, c.point_step);
  for (const ExtraDim& d : named)
    detail::addField(c, d.name, d.datatype);
  step = c.point_step;
  return c.fields;
}

Layout readLayout(const std::string& head, std::uint64_t file_size, const ReadAt& read_at, std::uint64_t max_vlr_bytes)
{
  const HeaderView h = readHeader(head, file_size);
  Layout l;
  static_cast<Header&>(l) = h;
  LasInfo& li = l.info;
  li.version_minor = h.minor;
  li.point_format = static_cast<std::uint8_t>(h.format);
  li.record_length = h.record_length;
  li.compressed = h.compressed;
  li.file_source_id = at<std::uint16_t>(head, 4);
  li.global_encoding = at<std::uint16_t>(head, 6);
  std::memcpy(li.guid.data(), head.data() + 8, 16);
  li.system_identifier = fixedString(head, 26, 32);
  li.generating_software = fixedString(head, 58, 32);
  li.creation_day = at<std::uint16_t>(head, 90);
  li.creation_year = at<std::uint16_t>(head, 92);
  for (int a = 0; a < 3; ++a)
  {
    li.scale[a] = at<double>(head, 131 + 8 * a);
    li.offset[a] = at<double>(head, 155 + 8 * a);
  }
  std::uint64_t kept = 0;
  auto keep = [&](LasVlr&& v) {
    kept += v.data.size();
    if (kept > max_vlr_bytes)
      fail("its VLRs and EVLRs hold more than ", max_vlr_bytes >> 20, " MiB, more than this reader keeps");
    if (isLaszip(v) && !v.extended)
    {
      l.laszip = std::move(v.data);
      l.has_laszip = true;
    }
    else
      li.vlrs.push_back(std::move(v));
  };
  // VLRs, between the header and the points.
  if (h.vlr_count > (h.point_offset - h.header_size) / kVlrHeader + 1)
    fail("its header declares ", h.vlr_count, " VLRs; ", h.point_offset - h.header_size, " bytes cannot hold them");
  std::uint64_t pos = h.header_size;
  for (std::uint32_t k = 0; k < h.vlr_count; ++k)
  {
    LasVlr v;
    readVlr(read_at, pos, h.point_offset, false, v);
    keep(std::move(v));
  }
  // EVLRs, after the points (LAS 1.4; in 1.3 the one of the waveform data).
  if (h.minor >= 4)
  {
    l.evlr_start = at<std::uint64_t>(head, 235);
    l.evlr_count = at<std::uint32_t>(head, 243);
  }
  else if (h.minor == 3 && (li.global_encoding & 2u) != 0)
  {
    l.evlr_start = at<std::uint64_t>(head, 227);
    l.evlr_count = l.evlr_start != 0 ? 1 : 0;
  }
  if (l.evlr_count > 0)
  {
    if (l.evlr_start < h.point_offset || l.evlr_start > file_size ||
        l.evlr_count > (file_size - l.evlr_start) / kEvlrHeader)
      fail("its ", l.evlr_count, " EVLR(s) at byte ", l.evlr_start, " are outside the file of ", file_size, " bytes");
    std::uint64_t epos = l.evlr_start;
    for (std::uint64_t k = 0; k < l.evlr_count; ++k)
    {
      LasVlr v;
      readVlr(read_at, epos, file_size, true, v);
      keep(std::move(v));
    }
    if (!h.compressed && h.points > 0 && h.point_offset + h.points * h.record_length > l.evlr_start)
      fail("its points (", h.points, " of ", h.record_length, " bytes from byte ", h.point_offset,
           ") run into its EVLRs at byte ", l.evlr_start);
  }
  if (h.compressed && !l.has_laszip)
    fail("its point format says LAZ but it has no LASzip VLR");
  return l;
}

void decodeRecords(const Layout& layout, const std::uint8_t* raw, std::size_t n,
                   const std::vector<pcl::PCLPointField>& fields, std::uint32_t step, std::uint8_t* dst_records)
{
  const std::vector<Dim> dims = dimsOf(layout.format);
  const std::size_t extra = layout.extra();
  const std::size_t standard = lasStandardRecordLength(layout.format);
  const auto& scale = layout.info.scale;
  const auto& offset = layout.info.offset;
  for (std::size_t i = 0; i < n; ++i)
  {
    const std::uint8_t* src = raw + i * layout.record_length;
    std::uint8_t* dst = dst_records + i * step;
    for (int a = 0; a < 3; ++a)
      put<double>(dst + 8 * a, static_cast<double>(get<std::int32_t>(src + 4 * a)) * scale[a] + offset[a]);
    std::size_t f = 3;
    for (const Dim& d : dims)
    {
      std::uint8_t* out = dst + fields[f++].offset;
      if (d.bits == 0)
        std::memcpy(out, src + d.offset, d.size);
      else
      {
        const std::uint64_t v = readUnsigned(src + d.offset, d.size) >> d.shift;
        const std::uint64_t mask = (1ull << d.bits) - 1;
        writeUnsigned(out, detail::datatypeSize(d.datatype), v & mask);
      }
    }
    if (extra > 0)
      std::memcpy(dst + fields[f].offset, src + standard, extra);
  }
}

Encoder::Encoder(const std::vector<pcl::PCLPointField>& fields, std::uint32_t point_step, const LasInfo& info)
  : fields_(fields), step_(point_step), info_(info)
{
  imin.fill(std::numeric_limits<std::int32_t>::max());
  imax.fill(std::numeric_limits<std::int32_t>::min());
  auto fieldOf = [&](const char* name) -> const Field* {
    for (const Field& f : fields_)
      if (f.name == name && f.count >= 1 && detail::datatypeSize(f.datatype) > 0)
        return &f;
    return nullptr;
  };
  for (int a = 0; a < 3; ++a)
    xyz_[a] = fieldOf(a == 0 ? "x" : a == 1 ? "y" : "z");
  if (!xyz_[0] || !xyz_[1] || !xyz_[2])
    fail("the cloud has no x y z fields");
  const std::size_t standard = lasStandardRecordLength(info.point_format);
  if (standard == 0 || info.record_length < standard)
    fail("point format ", int{info.point_format}, " with records of ", info.record_length, " bytes cannot be written");
  packed_rgb_ = fieldOf("rgb") ? fieldOf("rgb") : fieldOf("rgba");
  extra_field_ = fieldOf("extra_bytes");
  if (extra_field_ && (extra_field_->datatype != Field::UINT8 || extra_field_->count > info.record_length - standard))
    extra_field_ = nullptr;
  // Extra dimensions of the header the cloud has a field for (addLasExtraDimensions): written after
  // the extra bytes the cloud holds. A header whose Extra Bytes VLR cannot be read names none, and
  // a descriptor named as a field every LAS record has (x, intensity, ...) is not one: a cloud read
  // from a LAS file is written back byte for byte whatever its VLR says.
  std::vector<ExtraDim> dims;
  std::string why;
  if (extraDims(info, dims, why))
    for (const ExtraDim& d : dims)
      if (const Field* f = fieldOf(d.name.c_str());
          f && d.datatype != 0 && !isLasFieldName(d.name) && standard + d.offset + d.size <= info.record_length)
        named_.emplace_back(d, f);
  for (const Dim& d : dimsOf(info.point_format))
  {
    Source s{d.datatype, d.offset, d.size, d.shift, d.bits, fieldOf(d.name), -1};
    if (!s.field && packed_rgb_ && (std::strcmp(d.name, "red") == 0 || std::strcmp(d.name, "green") == 0 ||
                                    std::strcmp(d.name, "blue") == 0))
      s.rgb_shift = d.name[0] == 'r' ? 16 : d.name[0] == 'g' ? 8 : 0;
    if (s.field || s.rgb_shift >= 0)
      sources_.push_back(s);
  }
}

void Encoder::encode(const std::uint8_t* records, std::size_t n, std::uint64_t first, std::vector<std::uint8_t>& out)
{
  const std::size_t len = info_.record_length;
  const std::size_t standard = lasStandardRecordLength(info_.point_format);
  const std::size_t base = out.size();
  out.resize(base + n * len, 0);
  for (std::size_t i = 0; i < n; ++i)
  {
    const std::uint8_t* src = records + i * step_;
    std::uint8_t* dst = out.data() + base + i * len;
    for (int a = 0; a < 3; ++a)
    {
      const double c = detail::loadValue(xyz_[a]->datatype, src + xyz_[a]->offset);
      const double q = std::round((c - info_.offset[a]) / info_.scale[a]);
      if (!(q >= -2147483648.0 && q <= 2147483647.0))
        fail("point ", first + i, "'s ", "xyz"[a], " = ", c, " does not fit the LAS scale ", info_.scale[a],
             " and offset ", info_.offset[a]);
      const auto v = static_cast<std::int32_t>(q);
      put<std::int32_t>(dst + 4 * a, v);
      imin[a] = std::min(imin[a], v);
      imax[a] = std::max(imax[a], v);
    }
    for (const Source& s : sources_)
    {
      const Source& d = s;
      double v = 0.0;
      if (s.field)
        v = detail::loadValue(s.field->datatype, src + s.field->offset);
      else
      {
        std::uint32_t p = 0;
        std::memcpy(&p, src + packed_rgb_->offset, 4);
        v = static_cast<double>((p >> s.rgb_shift) & 0xFFu) * 257.0;
      }
      if (d.bits == 0)
      {
        if (s.field && s.field->datatype == d.datatype)
          std::memcpy(dst + d.offset, src + s.field->offset, d.size);
        else
          detail::storeValue(v, d.datatype, dst + d.offset);
        continue;
      }
      const double top = static_cast<double>((1ull << d.bits) - 1);
      const auto u = static_cast<std::uint64_t>(std::clamp(std::isfinite(v) ? std::round(v) : 0.0, 0.0, top));
      const std::uint64_t mask = ((1ull << d.bits) - 1) << d.shift;
      const std::uint64_t old = readUnsigned(dst + d.offset, d.size);
      writeUnsigned(dst + d.offset, d.size, (old & ~mask) | ((u << d.shift) & mask));
    }
    if (extra_field_)
      std::memcpy(dst + standard, src + extra_field_->offset, extra_field_->count);
    for (const auto& [d, f] : named_)
    {
      std::uint8_t* at = dst + standard + d.offset;
      if (f->datatype == d.datatype)
        std::memcpy(at, src + f->offset, d.size);
      else
        detail::storeValue(detail::loadValue(f->datatype, src + f->offset), d.datatype, at);
    }
    const unsigned ret = info_.point_format <= 5 ? (dst[14] & 7u) : (dst[14] & 15u);
    if (ret >= 1 && ret <= 15)
      ++by_return[ret - 1];
  }
  count_ += n;
}

std::vector<std::uint8_t> laszipPayload(const LasInfo& info)
{
#ifdef PCL_ECS_HAVE_LAZ
  EcsLazBytes b{nullptr, 0, 0};
  char err[512] = {};
  const std::size_t extra = info.record_length - lasStandardRecordLength(info.point_format);
  if (ecs_laz_vlr(info.point_format, static_cast<std::uint16_t>(extra), &b, err, sizeof err) != 0)
    fail("LAZ: ", err);
  std::vector<std::uint8_t> payload(b.data, b.data + b.len);
  ecs_laz_free(&b);
  return payload;
#else
  (void)info;
  noLaz();
#endif
}

std::string headerBytes(const LasInfo& info, const Encoder& enc, const std::vector<std::uint8_t>& laszip,
                        std::vector<LasVlr>& evlrs)
{
  const std::uint64_t n = enc.count();
  const int format = info.point_format;
  const std::size_t header_size = info.version_minor >= 4 ? kHeader14 : info.version_minor == 3 ? kHeader13 : kHeader12;
  std::vector<LasVlr> vlrs;
  evlrs.clear();
  for (const LasVlr& v : info.vlrs)
    if (!isLaszip(v))
      (v.extended && info.version_minor >= 3 ? evlrs : vlrs).push_back(v);
  for (LasVlr& v : vlrs)
  {
    if (v.data.size() > 65535)
      fail("VLR \"", detail::quote(v.user_id), "\" ", v.record_id, " holds ", v.data.size(),
           " bytes, more than a LAS VLR can");
    v.extended = false;
  }
  if (!laszip.empty())
  {
    LasVlr v;
    v.user_id = kLaszipUser;
    v.record_id = kLaszipRecord;
    v.description = "laz-rs";
    v.data = laszip;
    vlrs.push_back(std::move(v));
  }
  std::string head(header_size, '\0');
  auto* hp = reinterpret_cast<std::uint8_t*>(&head[0]);
  std::memcpy(hp, "LASF", 4);
  put<std::uint16_t>(hp + 4, info.file_source_id);
  put<std::uint16_t>(hp + 6, info.global_encoding);
  std::memcpy(hp + 8, info.guid.data(), 16);
  hp[24] = 1;
  hp[25] = info.version_minor;
  std::memcpy(hp + 26, info.system_identifier.data(), std::min<std::size_t>(32, info.system_identifier.size()));
  std::memcpy(hp + 58, info.generating_software.data(), std::min<std::size_t>(32, info.generating_software.size()));
  put<std::uint16_t>(hp + 90, info.creation_day);
  put<std::uint16_t>(hp + 92, info.creation_year);
  put<std::uint16_t>(hp + 94, static_cast<std::uint16_t>(header_size));
  put<std::uint32_t>(hp + 100, static_cast<std::uint32_t>(vlrs.size()));
  hp[104] = static_cast<std::uint8_t>(format | (laszip.empty() ? 0 : 0x80));
  put<std::uint16_t>(hp + 105, info.record_length);
  const bool legacy = format <= 5 && n <= 0xFFFFFFFFull;
  put<std::uint32_t>(hp + 107, legacy ? static_cast<std::uint32_t>(n) : 0u);
  for (int r = 0; r < 5; ++r)
    put<std::uint32_t>(hp + 111 + 4 * r, legacy ? static_cast<std::uint32_t>(enc.by_return[r]) : 0u);
  for (int a = 0; a < 3; ++a)
  {
    put<double>(hp + 131 + 8 * a, info.scale[a]);
    put<double>(hp + 155 + 8 * a, info.offset[a]);
    put<double>(hp + 179 + 16 * a, n ? enc.imax[a] * info.scale[a] + info.offset[a] : 0.0);
    put<double>(hp + 187 + 16 * a, n ? enc.imin[a] * info.scale[a] + info.offset[a] : 0.0);
  }
  if (info.version_minor >= 4)
  {
    put<std::uint32_t>(hp + 243, static_cast<std::uint32_t>(evlrs.size()));
    put<std::uint64_t>(hp + 247, n);
    for (int r = 0; r < 15; ++r)
      put<std::uint64_t>(hp + 255 + 8 * r, enc.by_return[r]);
  }
  for (const LasVlr& v : vlrs)
    appendVlr(head, v);
  put<std::uint32_t>(reinterpret_cast<std::uint8_t*>(&head[0]) + 96, static_cast<std::uint32_t>(head.size()));
  return head;
}

std::string evlrBytes(const std::vector<LasVlr>& evlrs, std::uint64_t at, const LasInfo& info, std::string& head)
{
  std::string out;
  if (evlrs.empty())
    return out;
  std::uint64_t waveform = 0;
  for (const LasVlr& v : evlrs)
  {
    if (v.user_id == "LASF_Spec" && v.record_id == 65535 && waveform == 0)
      waveform = at + out.size();
    appendVlr(out, v);
  }
  auto* hp = reinterpret_cast<std::uint8_t*>(&head[0]);
  if (info.version_minor >= 4)
    put<std::uint64_t>(hp + 235, at);
  if ((info.global_encoding & 2u) != 0)
    put<std::uint64_t>(hp + 227, waveform);
  return out;
}

}  // namespace las

void probeLas(const std::string& header_bytes, std::uint64_t file_size, std::uint64_t& points,
              std::uint64_t& point_step)
{
  const HeaderView h = readHeader(header_bytes, file_size);
  std::uint32_t step = 0;
  las::cloudFields(h.format, h.record_length - lasStandardRecordLength(h.format), step);
  points = h.points;
  point_step = step;
}

void parseLas(const std::string& bytes, pcl::PCLPointCloud2& cloud, LasInfo* info)
{
  las::Layout l = las::readLayout(bytes, bytes.size(), [&](std::uint64_t offset, std::size_t n) {
    return offset >= bytes.size() ? std::string() : bytes.substr(static_cast<std::size_t>(offset), n);
  });
  const std::size_t n = static_cast<std::size_t>(l.points);
  if (n > 0xFFFFFFFFull)
    fail("it holds ", n, " points, more than a cloud can (2^32 - 1)");
  std::vector<std::uint8_t> raw;
  const std::uint8_t* rec = reinterpret_cast<const std::uint8_t*>(bytes.data()) + l.point_offset;
  if (l.compressed && n > 0)  // no points: nothing to decompress (the chunked reader agrees)
  {
#ifdef PCL_ECS_HAVE_LAZ
    raw.resize(n * l.record_length);
    char err[512] = {};
    if (ecs_laz_decompress(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size(), l.point_offset,
                           l.laszip.data(), l.laszip.size(), raw.data(), n, l.record_length, err, sizeof err) != 0)
      fail(err);
    rec = raw.data();
#else
    noLaz();
#endif
  }
  std::uint32_t step = 0;
  cloud = pcl::PCLPointCloud2();
  cloud.fields = las::cloudFields(l, step);
  cloud.point_step = step;
  cloud.width = static_cast<std::uint32_t>(n);
  cloud.height = 1;
  cloud.row_step = step * cloud.width;
  cloud.is_bigendian = false;
  cloud.data.resize(n * step);
  las::decodeRecords(l, rec, n, cloud.fields, step, cloud.data.data());
  detail::setDenseFlag(cloud);
  if (info)
    *info = std::move(l.info);
}

LasInfo defaultLasInfo(const std::vector<pcl::PCLPointField>& fields, const std::array<double, 3>& lo,
                       const std::array<double, 3>& hi)
{
  auto has = [&](const char* name) {
    return std::any_of(fields.begin(), fields.end(), [&](const Field& f) { return f.name == name; });
  };
  LasInfo info;
  const bool colour = has("rgb") || has("rgba") || (has("red") && has("green") && has("blue"));
  const bool time = has("gps_time");
  info.point_format = static_cast<std::uint8_t>(colour ? (time ? 3 : 2) : (time ? 1 : 0));
  info.record_length = static_cast<std::uint16_t>(lasStandardRecordLength(info.point_format));
  info.version_minor = 2;
  info.system_identifier = "pcl_ecs";
  double half = 0.0;
  for (int a = 0; a < 3; ++a)
  {
    info.offset[a] = lo[a] <= hi[a] ? std::floor(0.5 * (lo[a] + hi[a])) : 0.0;
    if (lo[a] <= hi[a])
      half = std::max({half, hi[a] - info.offset[a], info.offset[a] - lo[a]});
  }
  const double e = std::ceil(std::log10(std::max(half, 1e-300) / 1073741824.0));
  const double s = std::pow(10.0, std::clamp(e, -12.0, 12.0));
  info.scale = {s, s, s};
  return info;
}

void fitLasFrame(LasInfo& info, const std::array<double, 3>& lo, const std::array<double, 3>& hi)
{
  const auto fits = [&](int a) {
    const double q0 = std::round((lo[a] - info.offset[a]) / info.scale[a]);
    const double q1 = std::round((hi[a] - info.offset[a]) / info.scale[a]);
    return q0 >= -2147483648.0 && q1 <= 2147483647.0;
  };
  for (int a = 0; a < 3; ++a)
  {
    if (!(lo[a] <= hi[a]) || fits(a))
      continue;
    info.offset[a] = std::floor(0.5 * (lo[a] + hi[a]));
    for (int k = 0; k < 40 && !fits(a); ++k)
      info.scale[a] *= 10.0;
  }
}

bool isLasFieldName(const std::string& name)
{
  for (const char* own : {"x", "y", "z", "extra_bytes", "rgb", "rgba"})
    if (name == own)
      return true;
  for (int format = 0; format <= 10; ++format)
    for (const Dim& d : dimsOf(format))
      if (name == d.name)
        return true;
  return false;
}

LasInfo lasInfoFor(const pcl::PCLPointCloud2& cloud, const LasInfo* like)
{
  if (like)
    return *like;
  // The box of the finite points.
  const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
  std::array<double, 3> lo, hi;
  lo.fill(std::numeric_limits<double>::infinity());
  hi.fill(-std::numeric_limits<double>::infinity());
  for (int a = 0; a < 3; ++a)
  {
    const Field* f = nullptr;
    for (const Field& g : cloud.fields)
      if (g.name == std::string(1, "xyz"[a]) && detail::datatypeSize(g.datatype) > 0)
        f = &g;
    for (std::size_t i = 0; f && i < n; ++i)
    {
      const double v = detail::loadValue(f->datatype, cloud.data.data() + i * cloud.point_step + f->offset);
      if (std::isfinite(v))
      {
        lo[a] = std::min(lo[a], v);
        hi[a] = std::max(hi[a], v);
      }
    }
  }
  return defaultLasInfo(cloud.fields, lo, hi);
}

void addLasExtraDimensions(LasInfo& info, const std::vector<pcl::PCLPointField>& fields,
                           const std::vector<ExtraDimension>& add)
{
  const std::size_t standard = lasStandardRecordLength(info.point_format);
  if (standard == 0 || info.record_length < standard)
    fail("point format ", int{info.point_format}, " with records of ", info.record_length, " bytes cannot be written");
  std::vector<las::ExtraDim> dims;
  std::string why;
  if (!las::extraDims(info, dims, why))
    fail(why);
  std::size_t described = 0;
  for (const las::ExtraDim& d : dims)
    described += d.size;
  std::size_t extra = info.record_length - standard;
  if (described > extra)
    fail("its Extra Bytes VLR describes ", described, " bytes but its records hold ", extra, " extra bytes");
  auto vlr = std::find_if(info.vlrs.begin(), info.vlrs.end(), las::isExtraBytesVlr);
  if (vlr == info.vlrs.end())
  {
    LasVlr v;
    v.user_id = las::kSpecUser;
    v.record_id = las::kExtraBytesRecord;
    v.description = "Extra Bytes Record";
    info.vlrs.push_back(std::move(v));  // after the header's other VLRs
    vlr = std::prev(info.vlrs.end());
  }
  std::vector<std::uint8_t>& data = vlr->data;
  // Extra bytes no descriptor covers are described as undocumented, at most 255 to a descriptor.
  for (std::size_t left = extra - described; left > 0;)
  {
    const std::size_t part = std::min<std::size_t>(255, left);
    const std::vector<std::uint8_t> d = las::descriptor(0, part, "", "");
    data.insert(data.end(), d.begin(), d.end());
    left -= part;
  }
  for (const ExtraDimension& x : add)
  {
    const auto f = std::find_if(fields.begin(), fields.end(), [&](const Field& g) { return g.name == x.name; });
    if (f == fields.end())
      fail("the cloud has no field \"", detail::quote(x.name), "\" to write as an extra dimension");
    const std::uint8_t las_type = las::lasTypeOfPcl(f->datatype);
    if (las_type == 0 || f->count != 1 || x.name.empty() || x.name.size() > 31)
      fail("field \"", detail::quote(x.name), "\" is not one number with a name of 1 to 31 characters: it cannot be an extra dimension");
    if (isLasFieldName(x.name))
      fail("\"", detail::quote(x.name), "\" is the name of a LAS dimension: it cannot be an extra dimension");
    const auto same = std::find_if(dims.begin(), dims.end(), [&](const las::ExtraDim& d) { return d.name == x.name; });
    if (same != dims.end())
    {
      // The records hold this dimension already (a file this function wrote, simplified again):
      // its bytes are written over.
      if (same->datatype != f->datatype)
        fail("the records have an extra dimension \"", detail::quote(x.name), "\" of another type already");
      continue;
    }
    const std::size_t size = detail::datatypeSize(f->datatype);
    if (standard + extra + size > 65535)
      fail("records of ", standard + extra + size, " bytes: a LAS record holds at most 65,535");
    const std::vector<std::uint8_t> d = las::descriptor(las_type, 0, x.name, x.description);
    data.insert(data.end(), d.begin(), d.end());
    dims.push_back({x.name, extra, size, las_type, f->datatype});
    extra += size;
  }
  if (data.size() > 65535)
    fail("an Extra Bytes VLR of ", data.size(), " bytes: a LAS VLR holds at most 65,535");
  info.record_length = static_cast<std::uint16_t>(standard + extra);
}

std::string lasBytes(const pcl::PCLPointCloud2& cloud, const LasInfo* like, bool compressed)
{
#ifndef PCL_ECS_HAVE_LAZ
  if (compressed)
    noLaz();
#endif
  const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
  LasInfo info = lasInfoFor(cloud, like);
  info.generating_software = std::string("pcl_ecs ") + PCL_ECS_VERSION_STRING;
  las::Encoder enc(cloud.fields, cloud.point_step, info);
  std::vector<std::uint8_t> records;
  enc.encode(cloud.data.data(), n, 0, records);
  const std::vector<std::uint8_t> laszip = compressed ? las::laszipPayload(info) : std::vector<std::uint8_t>();
  std::vector<LasVlr> evlrs;
  std::string head = las::headerBytes(info, enc, laszip, evlrs);
  std::string file;
  if (compressed)
  {
#ifdef PCL_ECS_HAVE_LAZ
    EcsLazBytes b{nullptr, 0, 0};
    char err[512] = {};
    if (ecs_laz_compress(reinterpret_cast<const std::uint8_t*>(head.data()), head.size(), laszip.data(), laszip.size(),
                         records.data(), n, info.record_length, &b, err, sizeof err) != 0)
      fail("LAZ: ", err);
    file.assign(reinterpret_cast<const char*>(b.data), b.len);
    ecs_laz_free(&b);
#endif
  }
  else
  {
    file = head;
    file.append(reinterpret_cast<const char*>(records.data()), records.size());
  }
  const std::string tail = las::evlrBytes(evlrs, file.size(), info, head);
  file.replace(0, head.size(), head);
  return file + tail;
}

}  // namespace io
}  // namespace pcl_ecs
