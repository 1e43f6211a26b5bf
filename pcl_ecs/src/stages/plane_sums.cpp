#include "../detail/plane_sums.h"

#include <pcl_ecs/stages/kernel.h>

#include "../detail/simd.h"

#include <algorithm>

#ifdef __SSE2__
#include <emmintrin.h>
#endif
#ifdef PCL_ECS_HAVE_AVX2_PATH
#include <immintrin.h>
#endif

namespace pcl_ecs
{
namespace detail
{

namespace
{
void selectKernelPiecesPortable(const double* dist, std::size_t m, double inv_R, std::uint32_t* inner,
                                std::size_t& n_inner, std::uint32_t* outer, std::size_t& n_outer)
{
  n_inner = n_outer = 0;
#ifdef __SSE2__
  // Two distances per instruction; a pair's two masks pick the packing of its lanes (an odd m's
  // last pair ends with the +inf padding: in no piece).
  static constexpr std::uint32_t kLane[4][2] = {{0, 0}, {0, 0}, {1, 0}, {0, 1}};
  static constexpr std::uint32_t kCount[4] = {0, 1, 1, 2};
  const __m128d scale = _mm_set1_pd(inv_R), half = _mm_set1_pd(0.5), one = _mm_set1_pd(1.0);
  for (std::size_t j = 0; j < m; j += 2)
  {
    const __m128d t = _mm_mul_pd(_mm_loadu_pd(dist + j), scale);
    const int in = _mm_movemask_pd(_mm_cmple_pd(t, half));
    const int out = _mm_movemask_pd(_mm_and_pd(_mm_cmpgt_pd(t, half), _mm_cmple_pd(t, one)));
    const auto base = static_cast<std::uint32_t>(j);
    inner[n_inner] = base + kLane[in][0];
    inner[n_inner + 1] = base + kLane[in][1];
    n_inner += kCount[in];
    outer[n_outer] = base + kLane[out][0];
    outer[n_outer + 1] = base + kLane[out][1];
    n_outer += kCount[out];
  }
#else
  for (std::size_t j = 0; j < m; ++j)
  {
    const double t = dist[j] * inv_R;
    inner[n_inner] = static_cast<std::uint32_t>(j);
    outer[n_outer] = static_cast<std::uint32_t>(j);
    n_inner += t <= 0.5 ? 1 : 0;
    n_outer += (t > 0.5) & (t <= 1.0) ? 1 : 0;
  }
#endif
}

#ifdef PCL_ECS_HAVE_AVX2_PATH
/// Four distances per instruction; each mask's lanes packed by the shared compress table.
PCL_ECS_AVX2_TARGET void selectKernelPiecesAvx2(const double* dist, std::size_t m, double inv_R,
                                                std::uint32_t* inner, std::size_t& n_inner,
                                                std::uint32_t* outer, std::size_t& n_outer)
{
  std::size_t ni = 0, no = 0;
  const __m256d scale = _mm256_set1_pd(inv_R), half = _mm256_set1_pd(0.5), one = _mm256_set1_pd(1.0);
  for (std::size_t j = 0; j < m; j += 4)
  {
    const __m256d t = _mm256_mul_pd(_mm256_loadu_pd(dist + j), scale);
    const int in = _mm256_movemask_pd(_mm256_cmp_pd(t, half, _CMP_LE_OQ));
    const int out = _mm256_movemask_pd(
        _mm256_and_pd(_mm256_cmp_pd(t, half, _CMP_GT_OQ), _mm256_cmp_pd(t, one, _CMP_LE_OQ)));
    const __m128i base = _mm_set1_epi32(static_cast<int>(j));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(inner + ni),
                     _mm_add_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(kCompress8.lanes[in])), base));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(outer + no),
                     _mm_add_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(kCompress8.lanes[out])), base));
    ni += kCompress8.count[in];
    no += kCompress8.count[out];
  }
  n_inner = ni;
  n_outer = no;
}
#endif

/// kernelWeights: plain loops (the weights only add and multiply: see kernelInner), compiled
/// for SSE2 and again for AVX2 (two or four lanes per instruction, the same bits).
PCL_ECS_ALWAYS_INLINE void kernelWeightsBody(const double* dist, double inv_R, std::uint32_t* inner,
                                             std::size_t n_inner, const std::uint32_t* outer,
                                             std::size_t n_outer, double* g)
{
  // The ratios gathered first, then each piece's weights in a loop of their own (no gather, no
  // call: they vectorise).
  double* g_outer = g + n_inner;
  for (std::size_t s = 0; s < n_inner; ++s)
    g[s] = dist[inner[s]] * inv_R;
  for (std::size_t s = 0; s < n_outer; ++s)
    g_outer[s] = dist[outer[s]] * inv_R;
  for (std::size_t s = 0; s < n_inner; ++s)
    g[s] = kernelInner(g[s]);
  for (std::size_t s = 0; s < n_outer; ++s)
    g_outer[s] = kernelOuter(g_outer[s]);
  std::copy(outer, outer + n_outer, inner + n_inner);
}

void kernelWeightsPortable(const double* dist, double inv_R, std::uint32_t* inner, std::size_t n_inner,
                           const std::uint32_t* outer, std::size_t n_outer, double* g)
{
  kernelWeightsBody(dist, inv_R, inner, n_inner, outer, n_outer, g);
}

#ifdef PCL_ECS_HAVE_AVX2_PATH
PCL_ECS_AVX2_TARGET void kernelWeightsAvx2(const double* dist, double inv_R, std::uint32_t* inner,
                                           std::size_t n_inner, const std::uint32_t* outer,
                                           std::size_t n_outer, double* g)
{
  kernelWeightsBody(dist, inv_R, inner, n_inner, outer, n_outer, g);
}
#endif
}  // namespace

void selectKernelPieces(const double* dist, std::size_t m, double inv_R, std::uint32_t* inner,
                        std::size_t& n_inner, std::uint32_t* outer, std::size_t& n_outer)
{
#ifdef PCL_ECS_HAVE_AVX2_PATH
  if (useAvx2())
    return selectKernelPiecesAvx2(dist, m, inv_R, inner, n_inner, outer, n_outer);
#endif
  selectKernelPiecesPortable(dist, m, inv_R, inner, n_inner, outer, n_outer);
}

void kernelWeights(const double* dist, double inv_R, std::uint32_t* inner, std::size_t n_inner,
                   const std::uint32_t* outer, std::size_t n_outer, double* g)
{
#ifdef PCL_ECS_HAVE_AVX2_PATH
  if (useAvx2())
    return kernelWeightsAvx2(dist, inv_R, inner, n_inner, outer, n_outer, g);
#endif
  kernelWeightsPortable(dist, inv_R, inner, n_inner, outer, n_outer, g);
}

namespace
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
/// Three registers per plane; the even and the odd planes in two sets of running sums.
PCL_ECS_AVX2_TARGET void weightedPlaneSumAvx2(const CandidatePlanes::Terms* terms, const std::uint32_t* idx,
                                              const double* g, std::size_t count, double* sum)
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
#endif
}  // namespace

void weightedPlaneSum(const CandidatePlanes::Terms* terms, const std::uint32_t* idx, const double* g,
                      std::size_t count, double* sum)
{
#ifdef PCL_ECS_HAVE_AVX2_PATH
  if (useAvx2())
    return weightedPlaneSumAvx2(terms, idx, g, count, sum);
#endif
  weightedPlaneSumPortable(terms, idx, g, count, sum);
}

}  // namespace detail
}  // namespace pcl_ecs
