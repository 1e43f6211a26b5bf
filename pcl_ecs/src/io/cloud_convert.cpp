#include <pcl_ecs/io/cloud_convert.h>

#include "io_detail.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace pcl_ecs
{
namespace io
{

int fieldIndex(const std::vector<pcl::PCLPointField>& fields, const std::string& name)
{
  for (std::size_t k = 0; k < fields.size(); ++k)
    if (fields[k].name == name)
      return static_cast<int>(k);
  return -1;
}

std::uint32_t packedFields(const std::vector<pcl::PCLPointField>& fields, std::vector<pcl::PCLPointField>& packed)
{
  packed.clear();
  for (const auto& f : fields)
    if (f.name != "_" && f.count > 0 && detail::datatypeSize(f.datatype) > 0)
      packed.push_back(f);
  std::stable_sort(packed.begin(), packed.end(), [](const auto& a, const auto& b) { return a.offset < b.offset; });
  std::uint32_t at = 0;
  for (auto& f : packed)
  {
    f.offset = at;
    at += static_cast<std::uint32_t>(detail::datatypeSize(f.datatype) * f.count);
  }
  return at;
}

void copyRecords(const std::uint8_t* src, std::uint32_t src_step, const std::vector<pcl::PCLPointField>& src_fields,
                 const std::vector<std::int64_t>& from, std::uint8_t* dst, std::uint32_t dst_step,
                 const std::vector<pcl::PCLPointField>& dst_fields)
{
  struct Run
  {
    std::uint32_t src, dst, bytes;
  };
  std::vector<Run> runs;
  for (const auto& d : dst_fields)
  {
    const int s = fieldIndex(src_fields, d.name);
    if (s < 0 || src_fields[static_cast<std::size_t>(s)].datatype != d.datatype ||
        src_fields[static_cast<std::size_t>(s)].count != d.count)
      continue;
    const auto bytes = static_cast<std::uint32_t>(detail::datatypeSize(d.datatype) * d.count);
    const std::uint32_t so = src_fields[static_cast<std::size_t>(s)].offset;
    if (!runs.empty() && runs.back().src + runs.back().bytes == so && runs.back().dst + runs.back().bytes == d.offset)
      runs.back().bytes += bytes;  // adjacent on both sides: one copy
    else
      runs.push_back({so, d.offset, bytes});
  }
  for (std::size_t i = 0; i < from.size(); ++i)
  {
    const std::uint8_t* s = src + static_cast<std::size_t>(from[i]) * src_step;
    std::uint8_t* d = dst + i * dst_step;
    for (const Run& r : runs)
      std::memcpy(d + r.dst, s + r.src, r.bytes);
  }
}

pcl::PCLPointCloud2 packedCloud(const pcl::PCLPointCloud2& cloud)
{
  pcl::PCLPointCloud2 out;
  out.header = cloud.header;
  out.height = cloud.height;
  out.width = cloud.width;
  out.is_bigendian = cloud.is_bigendian;
  out.is_dense = cloud.is_dense;
  out.point_step = packedFields(cloud.fields, out.fields);
  out.row_step = out.point_step * out.width;
  if (out.point_step == cloud.point_step)
  {
    bool same = out.fields.size() == cloud.fields.size();
    for (std::size_t k = 0; same && k < out.fields.size(); ++k)
      same = out.fields[k].offset == cloud.fields[k].offset && out.fields[k].name == cloud.fields[k].name;
    if (same)
    {
      out.data = cloud.data;
      return out;
    }
  }
  const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
  std::vector<std::int64_t> all(n);
  for (std::size_t i = 0; i < n; ++i)
    all[i] = static_cast<std::int64_t>(i);
  out.data.assign(n * out.point_step, 0);
  copyRecords(cloud.data.data(), cloud.point_step, cloud.fields, all, out.data.data(), out.point_step, out.fields);
  return out;
}

std::size_t boundingBox(const pcl::PCLPointCloud2& cloud, Eigen::Vector3d& lo, Eigen::Vector3d& hi)
{
  const int idx[3] = {fieldIndex(cloud.fields, "x"), fieldIndex(cloud.fields, "y"), fieldIndex(cloud.fields, "z")};
  if (idx[0] < 0 || idx[1] < 0 || idx[2] < 0)
    return 0;
  Eigen::Vector3d l = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d h = -l;
  std::size_t finite = 0;
  const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
  for (std::size_t i = 0; i < n; ++i)
  {
    const std::uint8_t* rec = cloud.data.data() + i * cloud.point_step;
    Eigen::Vector3d p;
    for (int a = 0; a < 3; ++a)
    {
      const auto& f = cloud.fields[static_cast<std::size_t>(idx[a])];
      p[a] = detail::loadValue(f.datatype, rec + f.offset);
    }
    if (!p.allFinite())
      continue;
    ++finite;
    l = l.cwiseMin(p);
    h = h.cwiseMax(p);
  }
  if (finite > 0)
  {
    lo = l;
    hi = h;
  }
  return finite;
}

Eigen::Vector3d boundingBoxCentre(const pcl::PCLPointCloud2& cloud)
{
  Eigen::Vector3d lo, hi;
  return boundingBox(cloud, lo, hi) > 0 ? Eigen::Vector3d(0.5 * (lo + hi)) : Eigen::Vector3d::Zero();
}

void convertRecords(const pcl::PCLPointCloud2& cloud, const std::vector<pcl::PCLPointField>& dst_fields,
                    std::size_t dst_step, std::uint8_t* dst, const Eigen::Vector3d& shift)
{
  struct Map
  {
    const pcl::PCLPointField* src;
    const pcl::PCLPointField* dst;
    double shift;
    bool raw;  // copy the bytes as they are (packed colours)
  };
  std::vector<Map> maps;
  for (const auto& d : dst_fields)
  {
    int s = fieldIndex(cloud.fields, d.name);
    const bool colour = d.name == "rgb" || d.name == "rgba";
    if (s < 0 && colour)
      s = fieldIndex(cloud.fields, d.name == "rgb" ? "rgba" : "rgb");
    if (s < 0)
      continue;
    const pcl::PCLPointField& sf = cloud.fields[static_cast<std::size_t>(s)];
    if (detail::datatypeSize(sf.datatype) == 0 || detail::datatypeSize(d.datatype) == 0)
      continue;
    const double sh = d.name == "x" ? shift.x() : d.name == "y" ? shift.y() : d.name == "z" ? shift.z() : 0.0;
    const bool raw = colour && detail::datatypeSize(sf.datatype) == 4 && detail::datatypeSize(d.datatype) == 4;
    maps.push_back({&sf, &d, sh, raw});
  }
  const std::size_t n = static_cast<std::size_t>(cloud.width) * cloud.height;
  for (std::size_t i = 0; i < n; ++i)
  {
    const std::uint8_t* rec = cloud.data.data() + i * cloud.point_step;
    std::uint8_t* out = dst + i * dst_step;
    for (const Map& m : maps)
    {
      const std::uint32_t count = std::min(m.src->count, m.dst->count);
      const std::size_t ss = detail::datatypeSize(m.src->datatype), ds = detail::datatypeSize(m.dst->datatype);
      for (std::uint32_t c = 0; c < count; ++c)
      {
        const std::uint8_t* from = rec + m.src->offset + c * ss;
        std::uint8_t* to = out + m.dst->offset + c * ds;
        if (m.raw)
          std::memcpy(to, from, 4);
        else
          detail::storeValue(detail::loadValue(m.src->datatype, from) - m.shift, m.dst->datatype, to);
      }
    }
  }
}

std::uint32_t appendField(pcl::PCLPointCloud2& cloud, const std::string& name, std::uint8_t datatype,
                          std::uint32_t count)
{
  return detail::addField(cloud, name, datatype, count);
}

}  // namespace io
}  // namespace pcl_ecs
