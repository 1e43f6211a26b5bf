// Internal helpers shared by the readers and writers (not installed).
#pragma once

#include <cstdint>
#include <cstring>
#include <istream>
#include <sstream>
#include <string>
#include <vector>

#include <pcl/PCLPointCloud2.h>
#include <pcl_ecs/io/cloud_io.h>

namespace pcl_ecs
{
namespace io
{
namespace detail
{

/// The longest header line a reader accepts: a longer one is refused without being read whole.
constexpr std::size_t kMaxHeaderLine = 64u << 10;

/// Read one header line from `in` into `line` (without its '\n'): at most kMaxHeaderLine + 1
/// characters are kept and the rest of a longer line is not read (the caller refuses it). False at
/// the end of the stream with nothing read.
bool readHeaderLine(std::istream& in, std::string& line);

/// Size in bytes of a PCLPointField datatype (0 for an unknown one).
inline std::size_t datatypeSize(std::uint8_t datatype)
{
  switch (datatype)
  {
  case pcl::PCLPointField::INT8:
  case pcl::PCLPointField::UINT8: return 1;
  case pcl::PCLPointField::INT16:
  case pcl::PCLPointField::UINT16: return 2;
  case pcl::PCLPointField::INT32:
  case pcl::PCLPointField::UINT32:
  case pcl::PCLPointField::FLOAT32: return 4;
  case pcl::PCLPointField::FLOAT64:
  case pcl::PCLPointField::INT64:
  case pcl::PCLPointField::UINT64: return 8;
  default: return 0;
  }
}

/// Store `value` as `datatype` at `dst` (integers rounded and clamped to their range).
void storeValue(double value, std::uint8_t datatype, std::uint8_t* dst);
/// Read a value of `datatype` at `src` (host byte order; 64-bit integers beyond 2^53 rounded: copy
/// their bytes to keep them exact).
double loadValue(std::uint8_t datatype, const std::uint8_t* src);

/// Append a field to `cloud` (count 1) at the current end of a point; returns its offset.
std::uint32_t addField(pcl::PCLPointCloud2& cloud, const std::string& name, std::uint8_t datatype,
                       std::uint32_t count = 1);

/// Store one ascii PCD token as value of field `f` at `dst`; false unless it is a number. A float
/// `rgb` written as an unsigned integer (as PCL writes it) keeps those bits.
bool storeAsciiValue(const std::string& token, const pcl::PCLPointField& f, std::uint8_t* dst);

/// Parse a decimal number; false unless the whole token is one (nan / inf accepted for floats).
bool parseNumber(const std::string& token, double& value);

/// Input text as a message quotes it: at most 80 characters, anything but printable ASCII shown as
/// '?', "..." appended when cut.
std::string quote(const std::string& text);

template <typename... Args>
[[noreturn]] void fail(Args&&... args)
{
  std::ostringstream os;
  (os << ... << args);
  throw FormatError(os.str());
}

/// Finite x, y, z and a dense flag: PCL's is_dense means "no non-finite xyz".
void setDenseFlag(pcl::PCLPointCloud2& cloud);

}  // namespace detail
}  // namespace io
}  // namespace pcl_ecs
