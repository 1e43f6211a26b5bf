// tangent_frame.h: an orthonormal frame (u, v, n) around a unit normal, shared by the curvature
// fit (eq. 7-12) and the hull projection (step 6).
#pragma once

#include <cmath>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace pcl_ecs
{

/** \brief u, v such that (u, v, n) is a right-handed orthonormal frame; n must be unit length. */
inline void tangentFrame(const Eigen::Vector3d& n, Eigen::Vector3d& u, Eigen::Vector3d& v)
{
  const Eigen::Vector3d helper =
      std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  u = n.cross(helper).normalized();
  v = n.cross(u);
}

}  // namespace pcl_ecs
