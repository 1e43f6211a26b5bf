#include "point_dispatch.h"

#include <algorithm>

namespace pcl_ecs
{
namespace tools
{

PointKind choosePointKind(const pcl::PCLPointCloud2& cloud, std::string& dropped)
{
  auto has = [&](const char* name) {
    return std::any_of(cloud.fields.begin(), cloud.fields.end(),
                       [&](const pcl::PCLPointField& f) { return f.name == name; });
  };
  const bool normals = has("normal_x") && has("normal_y") && has("normal_z");
  const bool rgba = has("rgba");
  const bool rgb = has("rgb") || rgba;
  const bool intensity = has("intensity");
  const bool label = has("label");
  PointKind kind = PointKind::XYZ;
  if (normals)
    kind = rgb ? PointKind::XYZRGBNormal : intensity ? PointKind::XYZINormal : PointKind::Normal;
  else if (rgba)
    kind = PointKind::XYZRGBA;
  else if (rgb)
    kind = label ? PointKind::XYZRGBL : PointKind::XYZRGB;
  else if (intensity)
    kind = PointKind::XYZI;
  else if (label)
    kind = PointKind::XYZL;
  dropped.clear();
  auto drop = [&](const char* name) { dropped += (dropped.empty() ? "" : ", ") + std::string(name); };
  const bool keeps_label = kind == PointKind::XYZL || kind == PointKind::XYZRGBL;
  const bool keeps_intensity = kind == PointKind::XYZI || kind == PointKind::XYZINormal;
  const bool keeps_rgb = kind == PointKind::XYZRGB || kind == PointKind::XYZRGBA ||
                         kind == PointKind::XYZRGBL || kind == PointKind::XYZRGBNormal;
  if (label && !keeps_label) drop("label");
  if (intensity && !keeps_intensity) drop("intensity");
  if (rgb && !keeps_rgb) drop(rgba ? "rgba" : "rgb");
  return kind;
}

const char* pointKindName(PointKind kind)
{
  switch (kind)
  {
  case PointKind::XYZ: return "PointXYZ";
  case PointKind::XYZI: return "PointXYZI";
  case PointKind::XYZL: return "PointXYZL";
  case PointKind::XYZRGB: return "PointXYZRGB";
  case PointKind::XYZRGBA: return "PointXYZRGBA";
  case PointKind::XYZRGBL: return "PointXYZRGBL";
  case PointKind::Normal: return "PointNormal";
  case PointKind::XYZRGBNormal: return "PointXYZRGBNormal";
  case PointKind::XYZINormal: return "PointXYZINormal";
  }
  return "PointXYZ";
}

}  // namespace tools
}  // namespace pcl_ecs
