// uninitialised_allocator.h: a vector allocator that leaves new elements of a trivial type
// uninitialised (private to the library).
#pragma once

#include <memory>
#include <type_traits>
#include <utility>

namespace pcl_ecs
{

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

}  // namespace pcl_ecs
