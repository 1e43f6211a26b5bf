#include <pcl_ecs/stages/global_stats.h>

#include <cmath>

namespace pcl_ecs
{

void GlobalStats::addNonFeature(double spacing, double weight, double curvature)
{
  spacing_sum += spacing;
  radius_sum += std::sqrt(weight);
  abs_curvature_sum += std::abs(curvature);
  nonfeature_points += 1.0;
}

void GlobalStats::addMeasures(const std::vector<double>& measure)
{
  for (double m : measure)
    addMeasure(m);
}

void GlobalStats::addNonFeatures(const std::vector<double>& spacing, const std::vector<double>& weights,
                                 const std::vector<double>& curvature, const std::vector<std::uint8_t>& is_feature)
{
  for (std::size_t i = 0; i < is_feature.size(); ++i)
    if (!is_feature[i])
      addNonFeature(spacing[i], weights[i], curvature[i]);
}

void GlobalStats::merge(const GlobalStats& o)
{
  measure_sum += o.measure_sum;
  points += o.points;
  spacing_sum += o.spacing_sum;
  radius_sum += o.radius_sum;
  abs_curvature_sum += o.abs_curvature_sum;
  nonfeature_points += o.nonfeature_points;
}

}  // namespace pcl_ecs
