// representative_relax.h — after the cover (ball_cover.h), before the gap bound (gap_fill.h): one
// step of Lloyd's algorithm on the representatives, along the surface each one was fitted to.
//
// The cover puts a ball's representative near its centre, a point the seeded order picked. The
// points a representative stands for in the output (those nearer to it than to any other output
// point: its Voronoi cell among the outputs) then lie unevenly around it: more of them on the side
// away from the balls made before it. relaxRepresentatives moves every representative that lies on
// its ball's fitted quadratic (CoverBall::fitted, representative_fit.h) towards the centroid of its
// cell: in the centre's tangent plane, then onto the quadratic at the new tangent position. This
// is one step of the centroidal Voronoi relaxation, kept on the surface: the output spreads more
// evenly over the points it stands for, so the distance from an input point to its nearest output
// point falls, without the representative leaving the surface its ball fitted.
//
// What does not move: feature points (they are sites of the cells, so a representative is not drawn
// across a sharp edge), representatives that are not on a fit (rough balls and balls whose
// points were too few for it: their centres; balls across a crease: their optimised point, on the
// edge), balls whose cell holds no covered point, a representative whose new position would lie
// Parameters::max_representative_offset × r or farther from its centre, and one on a fit made near
// it (CoverBall::fit_support: a large ball's, representative_fit.h) whose new tangent position would
// lie that support or farther from where the fit was made. The cells are measured
// once, for every representative together (a Jacobi step), so the result does not depend on the
// order of the balls nor on the thread count.
#pragma once

#include <pcl_ecs/parameters.h>
#include <pcl_ecs/stages/ball_cover.h>

#include <cstddef>

namespace pcl_ecs
{

/** \brief Moves the fitted representatives of `out` (which coverWithBalls made from `in`) to the
 * tangent position of their Voronoi cell's centroid, on their fitted quadratic. The cells are those
 * of the output positions (outputPositions: kept feature points, then representatives) over the
 * covered points of `in` (owner >= 0); ties go to the lower output index. A moved ball's
 * attribute_source becomes the point of its cell nearest to its new representative (ties: the
 * lower index); its owner entries, radius, normal and error stay. Returns how many moved. Parallel
 * on `threads`; the result does not depend on them. */
std::size_t relaxRepresentatives(const CoverInput& in, double max_representative_offset, int threads, CoverOutput& out);

/** \brief The step as `params` asks: with its max_representative_offset and threads when
 * relax_representatives is on; nothing (0) when it is off. */
std::size_t relaxRepresentatives(const CoverInput& in, const Parameters& params, CoverOutput& out);

}  // namespace pcl_ecs
