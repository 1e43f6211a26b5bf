// feature_thinning.h (ours, target-size mode): feature points thinned along the edges to the
// spacing the target implies. On a noisy scan eq. 4 marks a band several points wide along every
// sharp edge; kept whole, that band takes most of a 3% or 1% budget (or more than all of it).
#pragma once

#include <pcl_ecs/types.h>

#include <cstdint>
#include <vector>

namespace pcl_ecs
{

/** \brief One feature point per `radius`: taken by decreasing measure (ties: lower index first),
 * a feature point is kept unless a kept one lies within `radius`; a dropped one is stood for by
 * the nearest kept one within `radius`. `kept_by[i]` is i for a kept feature point, the kept
 * feature point standing for it for a dropped one, −1 for the other points. Returns the number
 * kept. radius <= 0 keeps every feature point. Deterministic (sequential). */
std::size_t thinFeatures(const LocalCloud& cloud, const std::vector<std::uint8_t>& is_feature,
                         const std::vector<double>& measure, double radius, std::vector<std::int64_t>& kept_by);

}  // namespace pcl_ecs
