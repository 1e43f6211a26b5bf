// types.h: the plain values that flow between the stages.
#pragma once

#include <cstdint>
#include <memory>
#include <type_traits>
#include <utility>
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

/** \brief std::allocator, except that resize() leaves new elements of a trivial type
 * uninitialised instead of zeroing them: a large per-point array is first written (and its pages
 * first touched) by the parallel stage that fills every entry, not zeroed by one thread before. */
template <class T>
struct UninitialisedAllocator : std::allocator<T>
{
  template <class U>
  struct rebind
  {
    using other = UninitialisedAllocator<U>;
  };
  UninitialisedAllocator() = default;
  template <class U>
  UninitialisedAllocator(const UninitialisedAllocator<U>&) noexcept  // NOLINT(google-explicit-constructor)
  {
  }
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible<U>::value)
  {
    ::new (static_cast<void*>(p)) U;  // default-initialisation: nothing for int, float
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args)
  {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

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
