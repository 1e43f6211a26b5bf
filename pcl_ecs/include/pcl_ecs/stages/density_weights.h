// density_weights.h — paper eq. 1: a_i = (1/K) sum_j ||p_i - p_j||^2 over the K nearest
// neighbours (p_i excluded). Dense regions get small weights, so a sum of weights over a patch
// approximates its area and over-sampled overlaps of range scans do not dominate a quadric.
#pragma once

#include <pcl_ecs/neighborhood.h>

#include <vector>

namespace pcl_ecs
{

/** \brief Eq. 1 for every point of the table. Units: squared local-frame units.
 * \param[in] cloud the points the table was built on (distances by sqrDistance())
 * \param[in] table the K-neighbourhoods
 * \param[out] weights one a_i per point
 * \param[in] threads worker threads (the values do not depend on it) */
void computeDensityWeights(const LocalCloud& cloud, const NeighborhoodTable& table, std::vector<double>& weights,
                           int threads = 1);

}  // namespace pcl_ecs
