// simd.h — hot loops compiled twice, once for any x86-64 (SSE2) and once for AVX2, the version
// picked at run time (private to the library). A kernel's body is an always-inline function of
// plain loops that the compiler vectorises; two thin wrappers instantiate it, one with
// PCL_ECS_AVX2_TARGET. The target is "avx2" alone, never "fma": a fused multiply-add rounds once
// instead of twice, so both versions give the same bits (tests switch the AVX2 path off with
// allowAvx2(false) and compare).
#pragma once

#if defined(__x86_64__) && defined(__GNUC__)
#define PCL_ECS_HAVE_AVX2_PATH 1
#define PCL_ECS_AVX2_TARGET __attribute__((target("avx2")))
#endif
#define PCL_ECS_ALWAYS_INLINE inline __attribute__((always_inline))

namespace pcl_ecs
{
namespace detail
{

/** \brief True when the AVX2 versions run: the CPU has AVX2 and they are not switched off. */
bool useAvx2();

/** \brief Switch the AVX2 versions off (false) or back on where the CPU has them (tests). */
void allowAvx2(bool allow);

}  // namespace detail
}  // namespace pcl_ecs
