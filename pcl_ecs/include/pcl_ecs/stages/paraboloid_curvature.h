// paraboloid_curvature.h — paper eq. 7-12: in the local frame of p (origin p, z along n_p) fit
// z = a x² + b xy + c y² to p and its K neighbours by least squares (Householder QR) and take the
// mean curvature H = a + c. The sign of H flips with the normal: compare |H| (SPEC_NOTES).
#pragma once

#include <pcl_ecs/neighborhood.h>
#include <pcl_ecs/types.h>

#include <cstdint>
#include <vector>

namespace pcl_ecs
{

/** \brief Which paraboloid is fitted.
 * - Literal: eq. 7 as printed, z = a x² + b xy + c y², H = a + c. Exact when n_p is the true
 *   normal; a PCA normal tilted by ε adds a linear term the model cannot absorb, and on a sphere
 *   sampled with 16 neighbours that biases |H| by up to ~7%.
 * - Tilted (default): z = a x² + b xy + c y² + d x + e y, and H is the mean curvature of that
 *   graph at p (equal to a + c when d = e = 0). Absorbs the tilt: |H| within 3% of 1/ρ. */
enum class ParaboloidFit
{
  Literal,
  Tilted
};

/** \brief Fit eq. 7 to `points` (the centre among them or not) around `centre` with normal
 * `normal` and return H = a + c (eq. 11), in 1/units. For a sphere of radius ρ sampled densely,
 * |H| -> 1/ρ. Returns 0 when the fit is underdetermined (fewer distinct neighbours than
 * coefficients). At most the first 256 points are used (the method passes K <= 200). */
double paraboloidMeanCurvature(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal,
                               const std::vector<Eigen::Vector3d>& points,
                               ParaboloidFit fit = ParaboloidFit::Tilted);

/** \brief Eq. 11 for every non-feature point, with its table neighbours; feature points get 0. */
void computeMeanCurvature(const LocalCloud& cloud, const NormalList& normals,
                          const NeighborhoodTable& table,
                          const std::vector<std::uint8_t>& is_feature, int threads,
                          std::vector<double>& curvature,
                          ParaboloidFit fit = ParaboloidFit::Tilted);

}  // namespace pcl_ecs
