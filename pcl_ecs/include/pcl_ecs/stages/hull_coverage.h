// hull_coverage.h — paper section 4, step 6: project the non-feature points within r of c onto
// the plane tangent at c, take the 2D convex hull of the projections and mark as covered the
// points projected STRICTLY inside it. Points on the hull's boundary stay uncovered: they start
// later balls, which makes neighbouring balls overlap and leaves no holes. Fewer than three
// points, or a hull of zero area, covers nothing (the caller always covers c itself).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace pcl_ecs
{

/** \brief Convex hull of 2D points (Andrew's monotone chain), counter-clockwise, without
 * collinear vertices. Returns the indices of the hull vertices; empty for fewer than 3 points or
 * when all points are collinear. */
std::vector<int> convexHull2D(const std::vector<Eigen::Vector2d>& points);

/** \brief inside[i] = 1 when points[i] lies strictly inside the convex hull of `points`, i.e. at
 * a distance of more than `epsilon` from every hull edge, on its inner side. */
void strictlyInsideHull(const std::vector<Eigen::Vector2d>& points, double epsilon,
                        std::vector<std::uint8_t>& inside);

/** \brief Step 6 in 3D: offsets (p - c) projected onto the plane with unit normal n through c;
 * inside[i] = 1 for the offsets projected strictly inside the hull. The boundary tolerance is
 * 1e-9 of the largest projected extent. */
void hullCoverage(const Eigen::Vector3d& normal, const std::vector<Eigen::Vector3d>& offsets,
                  std::vector<std::uint8_t>& inside);

}  // namespace pcl_ecs
