#include <pcl_ecs/stages/radius_solver.h>

#include <pcl_ecs/stages/kernel.h>

#include "../detail/plane_sums.h"
#include "../detail/simd.h"

#ifdef PCL_ECS_HAVE_AVX2_PATH
#include <immintrin.h>
#endif

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace pcl_ecs
{

double errorOf(const QuadricMinimum& minimum, double weight_sum, double L, ErrorForm form)
{
  if (!(weight_sum > 0.0) || !(L > 0.0))
    return 0.0;
  const double q = std::max(0.0, minimum.value);
  return form == ErrorForm::Paper ? std::sqrt(q) / L : std::sqrt(q / weight_sum) / L;
}

namespace
{
/// The terms of candidate i's plane (one at a time; candidatePlanesAvx2 does four with the same
/// operations in the same order).
inline void planeTerms(const QuadricSamples& samples, const Eigen::Vector3d& centre,
                       const BallCandidate& candidate, double* t)
{
  const auto j = static_cast<std::size_t>(candidate.index);
  const Eigen::Vector3f& nf = samples.normals[j];
  const pcl::PointXYZ& p = samples.cloud[candidate.index];
  const double n0 = nf.x(), n1 = nf.y(), n2 = nf.z();
  const double o0 = static_cast<double>(p.x) - centre.x(), o1 = static_cast<double>(p.y) - centre.y(),
               o2 = static_cast<double>(p.z) - centre.z();
  const double a = samples.weights[j], d = (n0 * o0 + n1 * o1) + n2 * o2;
  const double an0 = a * n0, an1 = a * n1, an2 = a * n2;
  t[0] = an0 * n0;
  t[1] = an0 * n1;
  t[2] = an0 * n2;
  t[3] = an1 * n1;
  t[4] = an1 * n2;
  t[5] = an2 * n2;
  t[6] = an0 * d;
  t[7] = an1 * d;
  t[8] = an2 * d;
  t[9] = (a * d) * d;
  t[10] = a;
  t[11] = 0.0;
}

#ifdef PCL_ECS_HAVE_AVX2_PATH
/// Candidates [first, last) four at a time (last - first a multiple of 4): each term computed for
/// four candidates in one register (double), then written candidate by candidate (4x4 transposes).
PCL_ECS_AVX2_TARGET void candidatePlanesAvx2(const QuadricSamples& samples, const Eigen::Vector3d& centre,
                                             const BallCandidate* candidates, std::size_t first,
                                             std::size_t last, CandidatePlanes::Terms* terms)
{
  const __m256d c0 = _mm256_set1_pd(centre.x()), c1 = _mm256_set1_pd(centre.y()),
                c2 = _mm256_set1_pd(centre.z());
  const pcl::PointXYZ* points = samples.cloud.points.data();
  const Eigen::Vector3f* normals = samples.normals.data();
  const double* weights = samples.weights.data();
  // The four rows [t(k) t(k+1) t(k+2) t(k+3)] of the four candidates from the four term vectors.
  auto store4 = [](__m256d ta, __m256d tb, __m256d tc, __m256d td, CandidatePlanes::Terms* out,
                   int k) PCL_ECS_AVX2_TARGET {
    const __m256d ab_lo = _mm256_unpacklo_pd(ta, tb), ab_hi = _mm256_unpackhi_pd(ta, tb);
    const __m256d cd_lo = _mm256_unpacklo_pd(tc, td), cd_hi = _mm256_unpackhi_pd(tc, td);
    _mm256_storeu_pd(out[0].t + k, _mm256_permute2f128_pd(ab_lo, cd_lo, 0x20));
    _mm256_storeu_pd(out[1].t + k, _mm256_permute2f128_pd(ab_hi, cd_hi, 0x20));
    _mm256_storeu_pd(out[2].t + k, _mm256_permute2f128_pd(ab_lo, cd_lo, 0x31));
    _mm256_storeu_pd(out[3].t + k, _mm256_permute2f128_pd(ab_hi, cd_hi, 0x31));
  };
  for (std::size_t i = first; i < last; i += 4)
  {
    const int j0 = candidates[i].index, j1 = candidates[i + 1].index, j2 = candidates[i + 2].index,
              j3 = candidates[i + 3].index;
    // Points (x, y, z, pad) and normals (x, y, z) of the four, transposed to coordinate vectors.
    __m128 p0 = _mm_load_ps(&points[j0].x), p1 = _mm_load_ps(&points[j1].x),
           p2 = _mm_load_ps(&points[j2].x), p3 = _mm_load_ps(&points[j3].x);
    _MM_TRANSPOSE4_PS(p0, p1, p2, p3);
    auto normal = [&](int j) PCL_ECS_AVX2_TARGET {
      const float* n = normals[j].data();
      // x, y by one 8-byte load (an unaligned type: a normal is only 4-byte aligned), then z.
      return _mm_movelh_ps(_mm_castsi128_ps(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(n))),
                           _mm_load_ss(n + 2));
    };
    __m128 m0 = normal(j0), m1 = normal(j1), m2 = normal(j2), m3 = normal(j3);
    _MM_TRANSPOSE4_PS(m0, m1, m2, m3);
    const __m256d n0 = _mm256_cvtps_pd(m0), n1 = _mm256_cvtps_pd(m1), n2 = _mm256_cvtps_pd(m2);
    const __m256d o0 = _mm256_sub_pd(_mm256_cvtps_pd(p0), c0), o1 = _mm256_sub_pd(_mm256_cvtps_pd(p1), c1),
                  o2 = _mm256_sub_pd(_mm256_cvtps_pd(p2), c2);
    const __m256d a = _mm256_set_pd(weights[j3], weights[j2], weights[j1], weights[j0]);
    const __m256d d = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(n0, o0), _mm256_mul_pd(n1, o1)),
                                    _mm256_mul_pd(n2, o2));
    const __m256d an0 = _mm256_mul_pd(a, n0), an1 = _mm256_mul_pd(a, n1), an2 = _mm256_mul_pd(a, n2);
    CandidatePlanes::Terms* out = terms + i;
    store4(_mm256_mul_pd(an0, n0), _mm256_mul_pd(an0, n1), _mm256_mul_pd(an0, n2), _mm256_mul_pd(an1, n1), out, 0);
    store4(_mm256_mul_pd(an1, n2), _mm256_mul_pd(an2, n2), _mm256_mul_pd(an0, d), _mm256_mul_pd(an1, d), out, 4);
    store4(_mm256_mul_pd(an2, d), _mm256_mul_pd(_mm256_mul_pd(a, d), d), a, _mm256_setzero_pd(), out, 8);
  }
}
#endif
}  // namespace

void candidatePlanes(const QuadricSamples& samples, const Eigen::Vector3d& centre,
                     const std::vector<BallCandidate>& candidates, CandidatePlanes& planes,
                     std::size_t first)
{
  // Distances padded to whole quadruples with +inf (in no piece of the kernel) for evaluateRadius.
  const std::size_t m = candidates.size();
  const std::size_t m4 = (m + 3) & ~std::size_t{3};
  planes.distance.resize(m4);
  for (std::size_t j = m; j < m4; ++j)
    planes.distance[j] = std::numeric_limits<double>::infinity();
  planes.terms.resize(m);
  for (std::size_t i = first; i < m; ++i)
    planes.distance[i] = candidates[i].distance;
  std::size_t i = first;
#ifdef PCL_ECS_HAVE_AVX2_PATH
  if (detail::useAvx2())
  {
    const std::size_t whole = first + ((m - std::min(first, m)) & ~std::size_t{3});
    candidatePlanesAvx2(samples, centre, candidates.data(), first, whole, planes.terms.data());
    i = whole;
  }
#endif
  for (; i < m; ++i)
    planeTerms(samples, centre, candidates[i], planes.terms[i].t);
}

RadiusEvaluation evaluateRadius(const CandidatePlanes& planes, double r, double L, ErrorForm form)
{
  RadiusEvaluation ev;
  ev.radius = r;
  const double R = 2.0 * r, inv_R = 1.0 / R;
  // The planes by the kernel's piece they fall in (collected without a branch per plane: which
  // piece is as good as random, and mispredicted branches cost more than the sums), then summed
  // in plane order, the inner piece first (detail::weightedPlaneSum). Distances are >= 0.
  const std::size_t m = planes.size();
  thread_local std::vector<std::uint32_t> inner, outer;
  inner.resize(m + 8);  // then the outer ones appended after the inner
  outer.resize(m + 8);
  std::size_t n_inner = 0, n_outer = 0;
  const double* dist = planes.distance.data();
  detail::selectKernelPieces(dist, m, inv_R, inner.data(), n_inner, outer.data(), n_outer);
  // The weights, then the weighted sums over both pieces (inner planes first, then outer).
  thread_local std::vector<double> g;
  g.resize(n_inner + n_outer);
  detail::kernelWeights(dist, inv_R, inner.data(), n_inner, outer.data(), n_outer, g.data());
  double sum[12];
  detail::weightedPlaneSum(planes.terms.data(), inner.data(), g.data(), n_inner + n_outer, sum);
  Quadric q;
  q.A << sum[0], sum[1], sum[2], sum[1], sum[3], sum[4], sum[2], sum[4], sum[5];
  q.b << sum[6], sum[7], sum[8];
  q.c = sum[9];
  q.weight_sum = sum[10];
  ev.minimum = minimizeQuadric(q);
  ev.quadric = q;
  ev.error = errorOf(ev.minimum, q.weight_sum, L, form);
  return ev;
}

RadiusEvaluation evaluateRadius(const QuadricSamples& samples, const Eigen::Vector3d& centre,
                                const std::vector<BallCandidate>& candidates, double r, double L,
                                ErrorForm form)
{
  CandidatePlanes planes;
  candidatePlanes(samples, centre, candidates, planes);
  return evaluateRadius(planes, r, L, form);
}

namespace
{
constexpr double kTight = 0.98;  // a bracket is done when lo >= kTight × hi

/// The radius search's bracket: the largest radius found with E <= tolerance (lo) and the
/// smallest found above it (hi), with the last two probes for the log-log model.
struct Bracket
{
  double lo = -1.0, hi = -1.0, e_lo = 0.0, e_hi = 0.0;
  bool last_passed = false;
  double prev_r = -1.0, prev_e = 0.0, last_r = -1.0, last_e = 0.0;  // the last two probes

  void record(double r, double e, bool passed)
  {
    prev_r = last_r;
    prev_e = last_e;
    last_r = r;
    last_e = e;
    last_passed = passed;
    if (passed)
    {
      lo = r;
      e_lo = e;
    }
    else
    {
      hi = r;
      e_hi = e;
    }
  }
  /// The local exponent of E ~ r^p from the last two probes (the slope in log-log), or
  /// `fallback` until there are two far enough apart.
  double localExponent(double fallback) const
  {
    if (prev_r > 0.0 && prev_e > 0.0 && last_e > 0.0 && std::abs(std::log(last_r / prev_r)) > 0.01)
      return std::min(std::max(std::log(last_e / prev_e) / std::log(last_r / prev_r), 0.5), 4.0);
    return fallback;
  }
};

/// Refine between the last good and the first bad radius (to 2%), probing with `probe`.
template <class Probe>
void refineBracket(Bracket& k, double tolerance, Probe probe)
{
  bool tried_closing = false;  // the last probe was a closing one that did not close
  for (int it = 0; k.hi > 0.0 && k.lo < kTight * k.hi && it < 10; ++it)
  {
    double theta = 0.5;
    if (k.e_lo > 0.0 && k.e_hi > k.e_lo)
      theta = std::log(tolerance / k.e_lo) / std::log(k.e_hi / k.e_lo);
    const double predicted = k.lo * std::pow(k.hi / k.lo, std::min(std::max(theta, 0.0), 1.0));
    if (k.hi * kTight * kTight <= k.lo)
    {
      // Any radius in [kTight hi, lo / kTight] closes the bracket, whether it passes or fails.
      probe(std::min(std::max(predicted, kTight * k.hi * 1.001), k.lo / kTight * 0.999));
      continue;
    }
    // When the model puts the root within 2% of the last probe, the probe 2% across closes the
    // bracket if the model is right (and shrinks it by 2% if not: then the next probe is held
    // inside the middle 80% of the bracket, so that the search never creeps).
    const bool close_above = k.last_passed && predicted < k.lo / kTight;
    const bool close_below = !k.last_passed && predicted > kTight * k.hi;
    if (!tried_closing && (close_above || close_below))
    {
      tried_closing = true;
      probe(close_above ? k.lo / kTight * 0.999 : kTight * k.hi * 1.001);
      continue;
    }
    tried_closing = false;
    const double r = close_above ? k.lo / kTight * 0.999 : close_below ? kTight * k.hi * 1.001 : predicted;
    const double ratio = std::log(r / k.lo) / std::log(k.hi / k.lo);
    probe(k.lo * std::pow(k.hi / k.lo, std::min(std::max(ratio, 0.1), 0.9)));
  }
}
}  // namespace

RadiusSolution solveRadius(const QuadricSamples& samples, const Eigen::Vector3d& centre,
                           double floor, double cap, double guess, double tolerance, double L,
                           ErrorForm form, CandidateSource& source,
                           std::vector<BallCandidate>& candidates)
{
  RadiusSolution sol;
  floor = std::min(std::max(floor, 0.0), cap);
  if (!(floor > 0.0))
    return sol;  // a duplicate of another point, or nothing around: the centre alone

  thread_local CandidatePlanes planes;  // kept from ball to ball: no allocation each
  planes.clear();
  auto eval = [&](double r) {
    // Candidates only grow (see CandidateSource): the planes of those held already stay valid.
    source.ensure(2.0 * r, candidates);
    if (planes.size() != candidates.size())
      candidatePlanes(samples, centre, candidates, planes,
                      planes.size() < candidates.size() ? planes.size() : 0);
    ++sol.evaluations;
    return evaluateRadius(planes, r, L, form);
  };
  auto accept = [&](const RadiusEvaluation& ev) {
    if (ev.radius <= sol.radius)
      return;
    sol.radius = ev.radius;
    sol.error = ev.error;
    sol.x_min = ev.minimum.x;
    sol.residual = std::max(0.0, ev.minimum.value);
    sol.quadric = ev.quadric;
  };

  // E grows roughly like a power of r (like r² on a smooth surface): each probe aims at the radius
  // where a log-log model through what is known predicts E = tolerance, and once a probe lands
  // near that radius the next one is placed to close the bracket from the other side (a pass just
  // below a fail, 2% apart) rather than creeping towards it from one side. The bracket keeps the
  // search safe where E is not monotone; the largest radius found with E <= tolerance is kept.
  Bracket k;
  // Evaluate r and move the matching end of the bracket; true when E(r) <= tolerance.
  auto probe = [&](double r) {
    const RadiusEvaluation ev = eval(r);
    k.record(r, ev.error, ev.error <= tolerance);
    if (k.last_passed)
      accept(ev);
    return k.last_passed;
  };

  const double start = std::min(std::max(guess, floor), cap);
  if (!probe(start))
  {
    if (!(start > floor))
      return sol;  // even the smallest ball is too coarse here: keep the centre alone
    // Too large: step down to just below where the model puts the root (E ~ r^p, p from the last
    // two probes, 2 until there are two), at most three times, then the floor. (On a noisy scan E
    // is far flatter than r^2 near the root; a probe at the floor would land far below it and
    // leave a wide bracket to refine.)
    for (int step = 0; k.lo < 0.0; ++step)
    {
      double aim = k.last_r * std::pow(tolerance / k.last_e, 1.0 / k.localExponent(2.0)) * 0.99;
      if (step >= 3 || !(aim > floor))
        aim = floor;
      probe(aim);
      if (aim == floor)
        break;
    }
    if (k.lo < 0.0)
      return sol;
  }
  // Grow until E exceeds the tolerance or the cap is reached: aim just below the radius where E
  // meets the tolerance, so that the next probe, just across it, closes the bracket.
  while (k.hi < 0.0 && k.lo < cap)
  {
    const double aim = k.e_lo > 0.0 ? k.lo * std::pow(tolerance / k.e_lo, 1.0 / k.localExponent(2.0)) * 0.995 : 2.0 * k.lo;
    probe(std::min(std::max(k.lo / kTight * 0.999, std::min(aim, 3.0 * k.lo)), cap));
  }
  refineBracket(k, tolerance, probe);
  return sol;
}

}  // namespace pcl_ecs
