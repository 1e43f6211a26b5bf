#include "io_detail.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace pcl_ecs
{
namespace io
{
namespace detail
{

namespace
{
template <typename T>
void storeAs(double v, std::uint8_t* dst)
{
  T t;
  if constexpr (std::is_integral_v<T> && sizeof(T) == 8)
  {
    // 2^63 and 2^64 are exact doubles; max() is not, so the bounds are compared, not cast.
    const double top = std::is_signed_v<T> ? 9223372036854775808.0 : 18446744073709551616.0;
    const double bottom = std::is_signed_v<T> ? -top : 0.0;
    v = std::isnan(v) ? 0.0 : std::round(v);
    t = v >= top ? std::numeric_limits<T>::max() : v <= bottom ? std::numeric_limits<T>::lowest() : static_cast<T>(v);
  }
  else if constexpr (std::is_integral_v<T>)
  {
    if (std::isnan(v))
      v = 0;
    v = std::min(std::max(std::round(v), static_cast<double>(std::numeric_limits<T>::lowest())),
                 static_cast<double>(std::numeric_limits<T>::max()));
    t = static_cast<T>(v);
  }
  else
  {
    t = static_cast<T>(v);
  }
  std::memcpy(dst, &t, sizeof(T));
}

template <typename T>
double loadAs(const std::uint8_t* src)
{
  T t;
  std::memcpy(&t, src, sizeof(T));
  return static_cast<double>(t);
}
}  // namespace

void storeValue(double value, std::uint8_t datatype, std::uint8_t* dst)
{
  switch (datatype)
  {
  case pcl::PCLPointField::INT8: storeAs<std::int8_t>(value, dst); break;
  case pcl::PCLPointField::UINT8: storeAs<std::uint8_t>(value, dst); break;
  case pcl::PCLPointField::INT16: storeAs<std::int16_t>(value, dst); break;
  case pcl::PCLPointField::UINT16: storeAs<std::uint16_t>(value, dst); break;
  case pcl::PCLPointField::INT32: storeAs<std::int32_t>(value, dst); break;
  case pcl::PCLPointField::UINT32: storeAs<std::uint32_t>(value, dst); break;
  case pcl::PCLPointField::FLOAT32: storeAs<float>(value, dst); break;
  case pcl::PCLPointField::FLOAT64: storeAs<double>(value, dst); break;
  case pcl::PCLPointField::INT64: storeAs<std::int64_t>(value, dst); break;
  case pcl::PCLPointField::UINT64: storeAs<std::uint64_t>(value, dst); break;
  default: break;
  }
}

double loadValue(std::uint8_t datatype, const std::uint8_t* src)
{
  switch (datatype)
  {
  case pcl::PCLPointField::INT8: return loadAs<std::int8_t>(src);
  case pcl::PCLPointField::UINT8: return loadAs<std::uint8_t>(src);
  case pcl::PCLPointField::INT16: return loadAs<std::int16_t>(src);
  case pcl::PCLPointField::UINT16: return loadAs<std::uint16_t>(src);
  case pcl::PCLPointField::INT32: return loadAs<std::int32_t>(src);
  case pcl::PCLPointField::UINT32: return loadAs<std::uint32_t>(src);
  case pcl::PCLPointField::FLOAT32: return loadAs<float>(src);
  case pcl::PCLPointField::FLOAT64: return loadAs<double>(src);
  case pcl::PCLPointField::INT64: return loadAs<std::int64_t>(src);
  case pcl::PCLPointField::UINT64: return loadAs<std::uint64_t>(src);
  default: return 0.0;
  }
}

std::uint32_t addField(pcl::PCLPointCloud2& cloud, const std::string& name, std::uint8_t datatype,
                       std::uint32_t count)
{
  pcl::PCLPointField f;
  f.name = name;
  f.datatype = datatype;
  f.count = count;
  f.offset = cloud.point_step;
  cloud.fields.push_back(f);
  cloud.point_step += static_cast<std::uint32_t>(datatypeSize(datatype) * count);
  return f.offset;
}

bool readHeaderLine(std::istream& in, std::string& line)
{
  line.clear();
  int c;
  while ((c = in.get()) != EOF && c != '\n')
  {
    line.push_back(static_cast<char>(c));
    if (line.size() > kMaxHeaderLine)
      return true;
  }
  return !(c == EOF && line.empty());
}

std::string quote(const std::string& text)
{
  constexpr std::size_t kMax = 80;
  std::string out;
  for (std::size_t i = 0; i < text.size() && i < kMax; ++i)
  {
    const auto c = static_cast<unsigned char>(text[i]);
    out += c >= 0x20 && c < 0x7f ? static_cast<char>(c) : '?';
  }
  if (text.size() > kMax)
    out += "...";
  return out;
}

bool parseNumber(const std::string& token, double& value)
{
  if (token.empty())
    return false;
  const char* begin = token.c_str();
  char* end = nullptr;
  errno = 0;
  value = std::strtod(begin, &end);
  if (end != begin + token.size())
    return false;
  if (errno == ERANGE && std::isinf(value))
    return false;  // overflow; an underflow to a subnormal or zero is a number all the same
  return true;
}

bool storeAsciiValue(const std::string& token, const pcl::PCLPointField& f, std::uint8_t* dst)
{
  if (f.datatype == pcl::PCLPointField::INT64 || f.datatype == pcl::PCLPointField::UINT64)
  {
    // Exactly, not through a double.
    const bool is_signed = f.datatype == pcl::PCLPointField::INT64;
    if (token.empty() || token.find_first_not_of(is_signed ? "-0123456789" : "0123456789") != std::string::npos)
      return false;
    errno = 0;
    char* end = nullptr;
    if (is_signed)
    {
      const long long v = std::strtoll(token.c_str(), &end, 10);
      std::memcpy(dst, &v, 8);
    }
    else
    {
      const unsigned long long v = std::strtoull(token.c_str(), &end, 10);
      std::memcpy(dst, &v, 8);
    }
    return errno == 0 && end && *end == '\0';
  }
  double v = 0.0;
  if (!parseNumber(token, v))
    return false;
  if (f.datatype == pcl::PCLPointField::FLOAT32 && f.name == "rgb" && v >= 0.0 && v <= 4294967295.0 &&
      token.find_first_not_of("0123456789") == std::string::npos)
  {
    const auto bits = static_cast<std::uint32_t>(v);
    std::memcpy(dst, &bits, 4);
    return true;
  }
  storeValue(v, f.datatype, dst);
  return true;
}

void setDenseFlag(pcl::PCLPointCloud2& cloud)
{
  int ix = -1, iy = -1, iz = -1;
  for (std::size_t f = 0; f < cloud.fields.size(); ++f)
  {
    if (cloud.fields[f].name == "x") ix = static_cast<int>(f);
    if (cloud.fields[f].name == "y") iy = static_cast<int>(f);
    if (cloud.fields[f].name == "z") iz = static_cast<int>(f);
  }
  cloud.is_dense = true;
  if (ix < 0 || iy < 0 || iz < 0)
    return;
  const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
  for (std::size_t i = 0; i < n && cloud.is_dense; ++i)
    for (int f : {ix, iy, iz})
    {
      const auto& fld = cloud.fields[static_cast<std::size_t>(f)];
      const double v = loadValue(fld.datatype, cloud.data.data() + i * cloud.point_step + fld.offset);
      if (!std::isfinite(v))
      {
        cloud.is_dense = false;
        break;
      }
    }
}

}  // namespace detail
}  // namespace io
}  // namespace pcl_ecs
