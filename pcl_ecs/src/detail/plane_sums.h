// plane_sums.h — the two loops of every E(r) evaluation (eq. 13), private to the library: which
// planes fall in which piece of the kernel, and the weighted sum of their terms. Each has a
// portable version (SSE2 on x86-64) and an AVX2 one, picked at run time (simd.h); both do the
// same operations in the same order (separate multiplies and adds, never fused): the same bits.
#pragma once

#include <pcl_ecs/stages/radius_solver.h>

#include <cstddef>
#include <cstdint>

namespace pcl_ecs
{
namespace detail
{

/** \brief The planes in each piece of the kernel at R = 1 / inv_R: positions j < m with
 * dist[j] / R <= 1/2 into inner, with 1/2 < dist[j] / R <= 1 into outer, in order, and their
 * counts. dist is padded with +inf to a multiple of 4; inner and outer have room for m + 8. */
void selectKernelPieces(const double* dist, std::size_t m, double inv_R, std::uint32_t* inner,
                        std::size_t& n_inner, std::uint32_t* outer, std::size_t& n_outer);

/** \brief The kernel's weights of the selected planes: g[s] = kernelInner(dist[inner[s]] × inv_R)
 * for s < n_inner, then g[n_inner + s] = kernelOuter(dist[outer[s]] × inv_R); the outer positions
 * are appended to inner (which has room for both). */
void kernelWeights(const double* dist, double inv_R, std::uint32_t* inner, std::size_t n_inner,
                   const std::uint32_t* outer, std::size_t n_outer, double* g);

/** \brief sum[k] = Σ_s g[s] × terms[idx[s]].t[k], k < 12. The planes go alternately into two
 * running sums (even s, odd s), added at the end: two independent chains of additions, so one
 * plane's sums do not wait on the previous plane's. */
void weightedPlaneSum(const CandidatePlanes::Terms* terms, const std::uint32_t* idx, const double* g,
                      std::size_t count, double* sum);

}  // namespace detail
}  // namespace pcl_ecs
