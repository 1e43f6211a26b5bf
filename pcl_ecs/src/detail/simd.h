// simd.h — hot loops built twice, once for any x86-64 (SSE2) and once for AVX2, the version picked
// at run time by useAvx2() (private to the library). The AVX2 version is either the same plain
// loop compiled again in a function marked PCL_ECS_AVX2_TARGET (a PCL_ECS_ALWAYS_INLINE body and
// two thin wrappers) or written with AVX2 intrinsics where the compiler does not vectorise it.
// The target is "avx2" alone, never "fma": a fused multiply-add rounds once instead of twice, so
// both versions give the same bits (tests switch the AVX2 path off with allowAvx2(false) and
// compare).
#pragma once

#if defined(__x86_64__) && defined(__GNUC__)
#define PCL_ECS_HAVE_AVX2_PATH 1
#define PCL_ECS_AVX2_TARGET __attribute__((target("avx2")))
#endif
#define PCL_ECS_ALWAYS_INLINE inline __attribute__((always_inline))

#include <cstdint>

namespace pcl_ecs
{
namespace detail
{

/** \brief True when the AVX2 versions run: the CPU has AVX2 and they are not switched off. */
bool useAvx2();

/** \brief Switch the AVX2 versions off (false) or back on where the CPU has them (tests). */
void allowAvx2(bool allow);

/** \brief For each 8-bit mask of lanes: the lanes it selects packed to the front (then zeros) and
 * how many: one permutation packs the selected elements of an eight-lane register. */
struct CompressTable
{
  std::int32_t lanes[256][8];
  std::uint8_t count[256];
};

constexpr CompressTable makeCompressTable()
{
  CompressTable t{};
  for (int mask = 0; mask < 256; ++mask)
  {
    int c = 0;
    for (int l = 0; l < 8; ++l)
      if (mask & (1 << l))
        t.lanes[mask][c++] = l;
    t.count[mask] = static_cast<std::uint8_t>(c);
  }
  return t;
}

alignas(32) inline constexpr CompressTable kCompress8 = makeCompressTable();

}  // namespace detail
}  // namespace pcl_ecs
