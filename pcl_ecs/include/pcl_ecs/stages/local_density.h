// local_density.h — paper eq. 5-6, on the non-feature points only: dens_i is the distance from
// p_i to the nearest other non-feature point (larger means SPARSER); its mean is the reference
// of the adaptive tolerance (step 5) and the unit of the radius cap.
#pragma once

#include <pcl_ecs/neighborhood.h>
#include <pcl_ecs/types.h>

#include <cstdint>
#include <vector>

#include <pcl/search/search.h>

namespace pcl_ecs
{

/** \brief Eq. 5 for every non-feature point (feature points get 0).
 * The table answers for almost every point; a point whose K neighbours are all feature points asks
 * `search` (over all of `cloud`) for more neighbours until one is not a feature point.
 * \param[out] dens distance (not squared), local-frame units */
void computeLocalDensity(const LocalCloud& cloud, const NeighborhoodTable& table,
                         const std::vector<std::uint8_t>& is_feature,
                         const pcl::search::Search<pcl::PointXYZ>& search,
                         int threads, std::vector<double>& dens);

}  // namespace pcl_ecs
