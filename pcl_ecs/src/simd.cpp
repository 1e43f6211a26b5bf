#include "detail/simd.h"

#include <atomic>

namespace pcl_ecs
{
namespace detail
{
namespace
{
bool cpuHasAvx2()
{
#ifdef PCL_ECS_HAVE_AVX2_PATH
  static const bool have = __builtin_cpu_supports("avx2");
  return have;
#else
  return false;
#endif
}

std::atomic<bool> g_allowed{true};
}  // namespace

bool useAvx2()
{
  return cpuHasAvx2() && g_allowed.load(std::memory_order_relaxed);
}

void allowAvx2(bool allow)
{
  g_allowed.store(allow, std::memory_order_relaxed);
}

}  // namespace detail
}  // namespace pcl_ecs
