// point_dispatch.h — pick the PCL point type from a cloud's fields, so colour, intensity, normals
// and labels travel through a tool instead of being dropped by a fixed PointXYZ.
#pragma once

#include <string>

#include <pcl/PCLPointCloud2.h>
#include <pcl/point_types.h>

namespace pcl_ecs
{
namespace tools
{

enum class PointKind
{
  XYZ,
  XYZI,
  XYZL,
  XYZRGB,
  XYZRGBA,
  XYZRGBL,
  Normal,
  XYZRGBNormal,
  XYZINormal
};

/** \brief The richest supported point type whose fields the cloud carries:
 * normals + rgb → PointXYZRGBNormal; normals + intensity → PointXYZINormal; normals → PointNormal;
 * rgba → PointXYZRGBA; rgb + label → PointXYZRGBL; rgb → PointXYZRGB; intensity → PointXYZI;
 * label → PointXYZL; otherwise PointXYZ. `dropped` lists carried fields the type cannot hold. */
PointKind choosePointKind(const pcl::PCLPointCloud2& cloud, std::string& dropped);

/** \brief The PCL name of a point kind ("PointXYZRGB", ...). */
const char* pointKindName(PointKind kind);

/** \brief Call f(PointT{}) with the point type of `kind`. */
template <typename F>
decltype(auto) dispatchPointKind(PointKind kind, F&& f)
{
  switch (kind)
  {
  case PointKind::XYZI: return f(pcl::PointXYZI{});
  case PointKind::XYZL: return f(pcl::PointXYZL{});
  case PointKind::XYZRGB: return f(pcl::PointXYZRGB{});
  case PointKind::XYZRGBA: return f(pcl::PointXYZRGBA{});
  case PointKind::XYZRGBL: return f(pcl::PointXYZRGBL{});
  case PointKind::Normal: return f(pcl::PointNormal{});
  case PointKind::XYZRGBNormal: return f(pcl::PointXYZRGBNormal{});
  case PointKind::XYZINormal: return f(pcl::PointXYZINormal{});
  case PointKind::XYZ:
  default: return f(pcl::PointXYZ{});
  }
}

}  // namespace tools
}  // namespace pcl_ecs
