// kernel.h — the weight G_σ of eq. 13. The printed formula is garbled; the C¹ compactly supported
// kernel it means (SPEC_NOTES) is
//   G_σ(ρ) = exp(-8 (ρ/σ)²)          for |ρ| <= σ/2
//          = (16/e²) (1 - |ρ|/σ)⁴     for σ/2 < |ρ| <= σ
//          = 0                        beyond.
// Both pieces equal e⁻² at σ/2 with the same slope (-8/(e² σ)). In the method σ = R = 2r.
#pragma once

#include <cmath>

namespace pcl_ecs
{

/** \brief exp(u) for -2 <= u <= 0 (the inner piece's range): e⁻¹ times the Taylor series of e^y,
 * y = u + 1, to y¹⁸/18! (relative error below 1e-15 on the range). Only additions and
 * multiplications, so that a loop of it runs four lanes per instruction and gives the same bits
 * in every build (std::exp is a scalar call). */
inline double expOnKernelRange(double u)
{
  // Horner's scheme, written out (straight-line code: a loop of calls vectorises).
  const double y = u + 1.0;
  double p = 1.0 / 6402373705728000.0;  // 1/18!
  p = p * y + 1.0 / 355687428096000.0;
  p = p * y + 1.0 / 20922789888000.0;
  p = p * y + 1.0 / 1307674368000.0;
  p = p * y + 1.0 / 87178291200.0;
  p = p * y + 1.0 / 6227020800.0;
  p = p * y + 1.0 / 479001600.0;
  p = p * y + 1.0 / 39916800.0;
  p = p * y + 1.0 / 3628800.0;
  p = p * y + 1.0 / 362880.0;
  p = p * y + 1.0 / 40320.0;
  p = p * y + 1.0 / 5040.0;
  p = p * y + 1.0 / 720.0;
  p = p * y + 1.0 / 120.0;
  p = p * y + 1.0 / 24.0;
  p = p * y + 1.0 / 6.0;
  p = p * y + 0.5;
  p = p * y + 1.0;
  p = p * y + 1.0;
  return p * 0.36787944117144233;  // e⁻¹
}

/** \brief The inner piece of G_1: exp(-8 t²), for 0 <= t <= 1/2. */
inline double kernelInner(double t)
{
  return expOnKernelRange(-8.0 * t * t);
}

/** \brief The outer piece of G_1: (16/e²) (1 - t)⁴, for 1/2 < t <= 1. */
inline double kernelOuter(double t)
{
  const double s = 1.0 - t;
  return 16.0 * std::exp(-2.0) * s * s * s * s;
}

/** \brief G_σ(ρ) as a function of t = |ρ| / σ >= 0 (G_1(t)). */
inline double kernelOfRatio(double t)
{
  if (t <= 0.5)
    return kernelInner(t);
  if (t <= 1.0)
    return kernelOuter(t);
  return 0.0;
}

/** \brief G_σ(ρ); σ > 0, ρ a distance (not squared). */
inline double kernelG(double rho, double sigma)
{
  return kernelOfRatio(std::abs(rho) / sigma);
}

}  // namespace pcl_ecs
