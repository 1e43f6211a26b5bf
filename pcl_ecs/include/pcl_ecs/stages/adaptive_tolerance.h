// adaptive_tolerance.h — paper section 4.4, step 5: adjust T_err per ball with the local mean
// curvature |H_c| (eq. 11) and density dens_c (eq. 5) against their means (eq. 12, 6):
//   flatter (|H_c| < mean) and sparser (dens_c > mean)   → T_err · factor (larger balls)
//   more curved (|H_c| > mean) and denser (dens_c < mean) → T_err / factor (smaller balls)
//   otherwise                                               → T_err
// The paper gives no factor; it is a parameter (Parameters::adaptive_factor).
#pragma once

#include <cmath>

namespace pcl_ecs
{

/** \brief The tolerance of one ball. `enabled` false, or factor 1, returns `base`. */
inline double adaptTolerance(double base, bool enabled, double factor, double abs_curvature,
                             double mean_abs_curvature, double dens, double mean_dens)
{
  if (!enabled)
    return base;
  const double h = std::abs(abs_curvature);
  if (h < mean_abs_curvature && dens > mean_dens)
    return base * factor;
  if (h > mean_abs_curvature && dens < mean_dens)
    return base / factor;
  return base;
}

}  // namespace pcl_ecs
