// feature_measure.h — paper eq. 3-4: measure(p) = (1/K) sum_j |(p - p_j) . n_p|, the mean distance
// of p's neighbours to its tangent plane; δ = α · mean(measure); p is a feature point when
// measure(p) > δ.
#pragma once

#include <pcl_ecs/neighborhood.h>
#include <pcl_ecs/types.h>

#include <cstdint>
#include <vector>

namespace pcl_ecs
{

/** \brief Eq. 3 for every point (local-frame units). Independent of the normals' sign. */
void computeFeatureMeasure(const LocalCloud& cloud, const NormalList& normals,
                           const NeighborhoodTable& table, int threads,
                           std::vector<double>& measure);

/** \brief is_feature[i] = measure[i] > delta. Returns the number of feature points. */
std::size_t classifyFeatures(const std::vector<double>& measure, double delta,
                             std::vector<std::uint8_t>& is_feature);

}  // namespace pcl_ecs
