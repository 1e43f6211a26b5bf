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

/** \brief The inner piece of G_1: exp(-8 t²), for 0 <= t <= 1/2. */
inline double kernelInner(double t)
{
  return std::exp(-8.0 * t * t);
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
