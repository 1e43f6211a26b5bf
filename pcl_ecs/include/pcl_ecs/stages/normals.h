// normals.h — paper eq. 2: the normal of p_i is the eigenvector of the smallest eigenvalue of the
// covariance of p_i and its K neighbours around their MEAN (the printed sum lacks the 1/K).
// Computed with PCL's own normal-estimation primitives (computeMeanAndCovarianceMatrix, eigen33:
// what pcl::NormalEstimation::computePointNormal does) on the shared neighbourhood table, so the
// K-nearest query is made once for every stage.
#pragma once

#include <pcl_ecs/neighborhood.h>
#include <pcl_ecs/types.h>

namespace pcl_ecs
{

/** \brief Eq. 2 for every point. Normals are unit length; their sign is arbitrary.
 * A neighbourhood whose points are all identical gets the normal (0, 0, 1).
 * \param[in] cloud   the points
 * \param[in] table   their K-neighbourhoods
 * \param[in] threads worker threads (>= 1)
 * \param[out] normals one unit normal per point */
void estimateNormals(const LocalCloud& cloud, const NeighborhoodTable& table, int threads,
                     NormalList& normals);

/** \brief Check user-given normals: all finite and of non-zero length; normalises them in place.
 * \return Status::BadNormals and the first bad index in `bad_index` otherwise. */
Status normalizeInputNormals(NormalList& normals, std::size_t& bad_index);

}  // namespace pcl_ecs
