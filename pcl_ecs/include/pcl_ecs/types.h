// types.h: the plain values that flow between the stages.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace pcl_ecs
{

/** \brief Positions in the local frame (input minus an origin near the cloud's centre), so that
 * float precision holds for coordinates in the millions (UTM). */
using LocalCloud = pcl::PointCloud<pcl::PointXYZ>;

/** \brief Unit normals, indexed like the LocalCloud. Sign is arbitrary: no stage depends on it. */
using NormalList = std::vector<Eigen::Vector3f>;

/** \brief What a stage says about its input. Stages never print; the filter reports. */
enum class Status
{
  Ok,
  TooFewPoints,    ///< fewer points than the neighbourhood needs
  Degenerate,      ///< the points do not span a surface (all identical, collinear)
  BadNormals,      ///< input normals requested but non-finite or zero
  InvalidArgument  ///< an argument outside its documented range
};

/** \brief A readable name for a status. */
inline const char* toString(Status s)
{
  switch (s)
  {
  case Status::Ok: return "ok";
  case Status::TooFewPoints: return "too few points";
  case Status::Degenerate: return "degenerate point set";
  case Status::BadNormals: return "bad input normals";
  case Status::InvalidArgument: return "invalid argument";
  }
  return "unknown";
}

}  // namespace pcl_ecs
