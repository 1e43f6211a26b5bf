#include "../plane_sums.h"

#ifdef __SSE2__
#include <emmintrin.h>
#endif
#include "../simd.h"

#ifdef PCL_ECS_HAVE_AVX2_PATH
#include <immintrin.h>
#endif

namespace pcl_ecs
{
namespace detail
{

void weightedPlaneSumPortable(const CandidatePlanes::Terms* terms, const std::uint32_t* idx,
                              const double* g, std::size_t count, double* sum)
{
  double acc[2][12] = {};
  for (std::size_t s = 0; s < count; ++s)
  {
    double* a = acc[s & 1];
    const double* t = terms[idx[s]].t;
#ifdef __SSE2__
    const __m128d w = _mm_set1_pd(g[s]);
    for (int k = 0; k < 12; k += 2)
      _mm_storeu_pd(a + k, _mm_add_pd(_mm_loadu_pd(a + k), _mm_mul_pd(w, _mm_loadu_pd(t + k))));
#else
    for (int k = 0; k < 12; ++k)
      a[k] += g[s] * t[k];
#endif
  }
  for (int k = 0; k < 12; ++k)
    sum[k] = acc[0][k] + acc[1][k];
}

#ifdef PCL_ECS_HAVE_AVX2_PATH
namespace
{
PCL_ECS_AVX2_TARGET void weightedPlaneSumAvx2(const CandidatePlanes::Terms* terms,
                                                          const std::uint32_t* idx, const double* g,
                                                          std::size_t count, double* sum)
{
  __m256d e0 = _mm256_setzero_pd(), e1 = e0, e2 = e0, o0 = e0, o1 = e0, o2 = e0;
  auto add = [](__m256d& a0, __m256d& a1, __m256d& a2, const double* t, double weight)
      PCL_ECS_AVX2_TARGET {
    const __m256d w = _mm256_set1_pd(weight);
    a0 = _mm256_add_pd(a0, _mm256_mul_pd(w, _mm256_loadu_pd(t)));
    a1 = _mm256_add_pd(a1, _mm256_mul_pd(w, _mm256_loadu_pd(t + 4)));
    a2 = _mm256_add_pd(a2, _mm256_mul_pd(w, _mm256_loadu_pd(t + 8)));
  };
  std::size_t s = 0;
  for (; s + 1 < count; s += 2)
  {
    add(e0, e1, e2, terms[idx[s]].t, g[s]);
    add(o0, o1, o2, terms[idx[s + 1]].t, g[s + 1]);
  }
  if (s < count)
    add(e0, e1, e2, terms[idx[s]].t, g[s]);
  _mm256_storeu_pd(sum, _mm256_add_pd(e0, o0));
  _mm256_storeu_pd(sum + 4, _mm256_add_pd(e1, o1));
  _mm256_storeu_pd(sum + 8, _mm256_add_pd(e2, o2));
}
}  // namespace
#endif

bool weightedPlaneSumWide(const CandidatePlanes::Terms* terms, const std::uint32_t* idx,
                          const double* g, std::size_t count, double* sum)
{
#ifdef PCL_ECS_HAVE_AVX2_PATH
  if (useAvx2())
  {
    weightedPlaneSumAvx2(terms, idx, g, count, sum);
    return true;
  }
#else
  (void)terms, (void)idx, (void)g, (void)count, (void)sum;
#endif
  return false;
}

void weightedPlaneSum(const CandidatePlanes::Terms* terms, const std::uint32_t* idx, const double* g,
                      std::size_t count, double* sum)
{
  if (!weightedPlaneSumWide(terms, idx, g, count, sum))
    weightedPlaneSumPortable(terms, idx, g, count, sum);
}

}  // namespace detail
}  // namespace pcl_ecs
