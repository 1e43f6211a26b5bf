// global_stats.h: the method's statistics over the whole cloud (δ of eq. 4, the means of eq. 6,
// of sqrt(a_i) of eq. 1 and of |H| of eq. 12) kept as sums, so that parts of a cloud can each add
// their own points and the parts merge. The in-memory run adds the whole cloud in index order; the
// tiled run adds each tile's own points and merges the tiles in tile order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace pcl_ecs
{

struct GlobalStats
{
  // Over every point (eq. 3-4).
  double measure_sum = 0;        ///< Σ measure (eq. 3)
  double points = 0;             ///< how many points
  // Over the non-feature points (eq. 5-6, 1, 12).
  double spacing_sum = 0;        ///< Σ dens_i (eq. 5)
  double radius_sum = 0;         ///< Σ sqrt(a_i) (eq. 1): the RMS distance to the K neighbours
  double abs_curvature_sum = 0;  ///< Σ |H_i| (eq. 11)
  double nonfeature_points = 0;  ///< how many non-feature points

  /// Add one point's feature measure.
  void addMeasure(double measure)
  {
    measure_sum += measure;
    points += 1.0;
  }
  /// Add one non-feature point's spacing, weight a_i and curvature H_i.
  void addNonFeature(double spacing, double weight, double curvature);
  /// Add every entry of `measure`, in index order.
  void addMeasures(const std::vector<double>& measure);
  /// Add every non-feature point i (is_feature[i] == 0), in index order.
  void addNonFeatures(const std::vector<double>& spacing, const std::vector<double>& weights,
                      const std::vector<double>& curvature, const std::vector<std::uint8_t>& is_feature);
  /// The sums of another part of the cloud.
  void merge(const GlobalStats& other);

  /// δ = α × mean measure (eq. 4); 0 for no points.
  double featureThreshold(double alpha) const { return points > 0 ? alpha * measure_sum / points : 0.0; }
  /// The mean of eq. 3 over every point: the mean distance of a point's neighbours to its tangent
  /// plane, the scan's noise level where the surface is smooth (0 for no points).
  double meanMeasure() const { return points > 0 ? measure_sum / points : 0.0; }
  /// The means over the non-feature points (0 when there are none).
  double meanSpacing() const { return nonfeature_points > 0 ? spacing_sum / nonfeature_points : 0.0; }
  double neighborhoodRadius() const { return nonfeature_points > 0 ? radius_sum / nonfeature_points : 0.0; }
  double meanAbsCurvature() const { return nonfeature_points > 0 ? abs_curvature_sum / nonfeature_points : 0.0; }
};

}  // namespace pcl_ecs
