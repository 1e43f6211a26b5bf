// Plain-text XYZ: whitespace-separated columns, one point per line.
#include "io_detail.h"

#include <algorithm>
#include <cctype>
#include <cmath>

namespace pcl_ecs
{
namespace io
{

using detail::fail;

namespace
{
/// The numbers of every point line (comments after '#', separators: whitespace and commas), all
/// lines with the same column count; `columns` gets that count.
std::vector<double> readColumns(const std::string& bytes, std::size_t& columns)
{
  std::vector<double> values;
  columns = 0;
  std::size_t pos = 0;
  int line_no = 0;
  std::vector<double> row;
  std::string token;
  while (pos < bytes.size())
  {
    std::size_t eol = bytes.find('\n', pos);
    if (eol == std::string::npos)
      eol = bytes.size();
    ++line_no;
    row.clear();
    std::size_t i = pos;
    while (i < eol)
    {
      while (i < eol && (std::isspace(static_cast<unsigned char>(bytes[i])) || bytes[i] == ','))
        ++i;
      if (i < eol && bytes[i] == '#')
        break;
      const std::size_t b = i;
      while (i < eol && !std::isspace(static_cast<unsigned char>(bytes[i])) && bytes[i] != ',')
        ++i;
      if (i > b)
      {
        token.assign(bytes, b, i - b);
        double v = 0.0;
        if (!detail::parseNumber(token, v))
          fail("line ", line_no, ": '", detail::quote(token), "' is not a number: not an XYZ point file");
        row.push_back(v);
      }
    }
    pos = eol + 1;
    if (row.empty())
      continue;
    if (columns == 0)
    {
      columns = row.size();
      if (columns != 3 && columns != 4 && columns != 6 && columns != 7 && columns != 9)
        fail("line ", line_no, ": ", columns, " columns; expected 3 (x y z), 4 (+ intensity), "
             "6 (+ normals or r g b), 7 (+ r g b a) or 9 (+ normals + r g b)");
    }
    else if (row.size() != columns)
      fail("line ", line_no, ": ", row.size(), " columns where the first point had ", columns);
    values.insert(values.end(), row.begin(), row.end());
  }
  if (columns == 0)
    fail("no points in the file");
  return values;
}

/// What the columns after x y z hold (the column count and the values decide it).
struct XyzColumns
{
  bool normals = false, colour = false, alpha = false, intensity = false;
  std::size_t colour_col = 0;
};

XyzColumns classifyColumns(const std::vector<double>& values, std::size_t columns)
{
  const std::size_t n = values.size() / columns;
  XyzColumns k;
  auto isByte = [&](std::size_t c) {
    for (std::size_t i = 0; i < n; ++i)
    {
      const double v = values[i * columns + c];
      if (!(v >= 0.0 && v <= 255.0 && v == std::floor(v)))
        return false;
    }
    return true;
  };
  if (columns == 4)
    k.intensity = true;
  else if (columns == 6)
  {
    bool any_above_one = false;
    for (std::size_t i = 0; i < n && !any_above_one; ++i)
      for (std::size_t c = 3; c < 6; ++c)
        any_above_one = any_above_one || values[i * columns + c] > 1.0;
    k.colour = isByte(3) && isByte(4) && isByte(5) && any_above_one;
    k.normals = !k.colour;
    k.colour_col = 3;
  }
  else if (columns == 7)
  {
    if (!(isByte(3) && isByte(4) && isByte(5) && isByte(6)))
      fail("7 columns must be x y z r g b a with colours as integers in [0, 255]");
    k.colour = k.alpha = true;
    k.colour_col = 3;
  }
  else if (columns == 9)
  {
    if (!(isByte(6) && isByte(7) && isByte(8)))
      fail("9 columns must be x y z nx ny nz r g b with colours as integers in [0, 255]");
    k.normals = k.colour = true;
    k.colour_col = 6;
  }
  return k;
}

/// True when float would move a point by more than 1e-6 of the bounding-box diagonal (centimetre
/// UTM coordinates, for example): the coordinates are then kept as double, otherwise float, as PCL's.
bool needsDoubleCoordinates(const std::vector<double>& values, std::size_t columns)
{
  const std::size_t n = values.size() / columns;
  double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c)
    {
      const double v = values[i * columns + c];
      if (std::isfinite(v))
      {
        lo[c] = std::min(lo[c], v);
        hi[c] = std::max(hi[c], v);
      }
    }
  double diag2 = 0.0;
  for (int c = 0; c < 3; ++c)
    diag2 += hi[c] >= lo[c] ? (hi[c] - lo[c]) * (hi[c] - lo[c]) : 0.0;
  const double tolerance = 1e-6 * std::sqrt(diag2);
  bool wide = false;
  for (std::size_t i = 0; i < n * columns && !wide; ++i)
  {
    if (i % columns >= 3)
      continue;
    const double v = values[i];
    wide = std::isfinite(v) && std::abs(static_cast<double>(static_cast<float>(v)) - v) > tolerance;
  }
  return wide;
}
}  // namespace

void parseXyz(const std::string& bytes, pcl::PCLPointCloud2& cloud)
{
  cloud = pcl::PCLPointCloud2{};
  if (bytes.empty())
    fail("the file is empty");
  std::size_t columns = 0;
  const std::vector<double> values = readColumns(bytes, columns);
  const std::size_t n = values.size() / columns;
  const XyzColumns k = classifyColumns(values, columns);
  const bool normals = k.normals, colour = k.colour, alpha = k.alpha, intensity = k.intensity;
  const std::size_t colour_col = k.colour_col;
  const auto F = pcl::PCLPointField::FLOAT32;
  const bool wide = needsDoubleCoordinates(values, columns);
  const auto C = wide ? pcl::PCLPointField::FLOAT64 : F;
  const std::uint32_t ox = detail::addField(cloud, "x", C);
  detail::addField(cloud, "y", C);
  detail::addField(cloud, "z", C);
  std::uint32_t on = 0, oi = 0, oc = 0;
  if (normals)
  {
    on = detail::addField(cloud, "normal_x", F);
    detail::addField(cloud, "normal_y", F);
    detail::addField(cloud, "normal_z", F);
  }
  if (intensity)
    oi = detail::addField(cloud, "intensity", F);
  if (colour)
    oc = detail::addField(cloud, alpha ? "rgba" : "rgb", alpha ? pcl::PCLPointField::UINT32 : F);
  cloud.width = static_cast<std::uint32_t>(n);
  cloud.height = 1;
  cloud.row_step = cloud.point_step * cloud.width;
  cloud.data.assign(static_cast<std::size_t>(cloud.point_step) * n, 0);
  for (std::size_t i = 0; i < n; ++i)
  {
    std::uint8_t* dst = cloud.data.data() + i * cloud.point_step;
    const double* v = values.data() + i * columns;
    for (int c = 0; c < 3; ++c)
      detail::storeValue(v[c], C, dst + ox + detail::datatypeSize(C) * c);
    if (normals)
      for (int c = 0; c < 3; ++c)
        detail::storeValue(v[3 + c], F, dst + on + 4 * c);
    if (intensity)
      detail::storeValue(v[3], F, dst + oi);
    if (colour)
    {
      const auto byte = [&](std::size_t c) { return static_cast<std::uint32_t>(v[colour_col + c]); };
      const std::uint32_t a = alpha ? byte(3) : 255u;
      const std::uint32_t packed = byte(2) | (byte(1) << 8) | (byte(0) << 16) | (a << 24);
      std::memcpy(dst + oc, &packed, 4);
    }
  }
  detail::setDenseFlag(cloud);
}

}  // namespace io
}  // namespace pcl_ecs
