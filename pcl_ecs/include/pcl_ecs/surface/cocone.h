// cocone.h — the Cocone surface reconstruction (Amenta, Choi, Dey, Leekha 2002), with boundary
// detection after Dey and Giesen, as free functions. The Delaunay triangulation comes from CGAL
// (exact predicates); CGAL stays inside the implementation file.
//
// Pipeline (each step timed in CoconeStats):
//   1. Delaunay triangulation of the distinct finite points.
//   2. Poles: for a sample inside the convex hull, the farthest circumcentre of its Voronoi cell
//      (the positive pole) gives the axis v_p; for a hull sample, the sum of the outward normals of
//      its hull facets does. The negative pole (farthest circumcentre on the other side) gives h_p.
//   3. Cocone test: a Delaunay triangle is a candidate when its dual Voronoi edge (a segment
//      between two circumcentres, or a ray along a hull facet's outward normal) meets the cocone of
//      its vertices: the directions from p whose |cos| with v_p is at most cos(π/2 − θ).
//   4. Boundaries (optional): a sample is regular when its cocone is thin (r_p / h_p ≤ ρ) and its
//      axis agrees with its cocone neighbours'; only regular vertices' cocones are tested and a
//      triangle needs at least one regular vertex, so openings are not closed over.
//   5. Pruning: triangles at sharp edges (the triangles around an edge leave an angular gap above
//      3π/2) are removed, and so are dangling triangles (two free edges). A triangle with one free
//      edge is kept: removing those would erode a noisy surface from every small hole.
//   6. Extraction: a walk from the hull triangles at the two extreme-x vertices, oriented
//      outwards, walked together; across each edge the walk takes
//      the first triangle met when turning towards the outside, oriented consistently, the
//      flattest crossings first (so a sliver or a chord across a thin part, met early, cannot
//      turn the rest of the surface inside out).
//   7. Clean-up: an edge keeps at most two triangles, a vertex keeps its largest fan of triangles,
//      so the result is an oriented 2-manifold (possibly with boundary); each piece this leaves
//      after the first takes the orientation of the surface around it; notches are closed with
//      candidates, two loops facing each other across a missing strip are joined by a band, and
//      the other holes are closed by ear clipping; with the scan the cloud was simplified from
//      (open_tunnels), two facing caps of a bore are replaced by a band on its wall; the triangles
//      are then flipped where the other diagonal bends the surface less.
//   8. Optional watertight closing: every remaining boundary loop is sealed.
#pragma once

#include <Eigen/Core>

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

namespace pcl_ecs
{
namespace surface
{

using Triangle = std::array<std::uint32_t, 3>;

/** \brief Parameters; the defaults are the authors'. */
struct CoconeParameters
{
  /** θ: the cocone holds the directions within θ of the plane normal to the pole axis, i.e. it is
   * the complement of the double cone of half-angle π/2 − θ = 3π/8. Radians, in (0, π/2). */
  double cocone_angle = 0.39269908169872414;  // π/8
  /** Detect boundary / undersampled samples (Dey-Giesen) so that open surfaces stay open. */
  bool detect_boundaries = true;
  /** ρ of the ratio condition r_p / h_p ≤ ρ. */
  double boundary_ratio = 1.3;
  /** Normal condition: the pole axes of a sample and of its cocone neighbours make at most this
   * angle (radians, unoriented). */
  double boundary_normal_angle = 0.39269908169872414;  // π/8
  /** Pruning: an edge is sharp when two consecutive triangles around it make an angle above this
   * (radians). */
  double sharp_edge_angle = 4.71238898038469;  // 3π/2
  bool prune = true;
  /** Undersampled spots: a candidate triangle whose longest edge exceeds this multiple of the
   * largest local spacing among its vertices (the median length of the candidate edges at a vertex)
   * spans a gap in the sampling and is
   * refused (the gap stays a hole). 0 disables the guard. */
  double max_edge_ratio = 5.0;
  /** Boundary loops of at most this many edges are closed by ear clipping after extraction, when
   * every chord the clipping needs stays within the gap guard (max_edge_ratio × the local
   * spacing): the places where the walk met a sliver from two sides, slits along sharp edges and
   * spots a few samples short. An opening wider than the guard (a scan's border, a cut) stays
   * open whatever its length; a loop the clipping closes but for at most 8 vertices, whose last
   * chords are wider than the guard, keeps its triangles and that gap stays open
   * (CoconeStats::narrowed_loops). The bound only caps the work (quadratic in a loop's length).
   * Then small handles are cut out: a cycle of three edges that is no triangle and does not
   * separate the mesh runs around a handle a triangle or two wide, which the walk makes at sharp
   * edges and corners; the triangles at its vertices are removed and the holes closed the same
   * way, and the cut is undone unless every hole closes and a handle is gone
   * (CoconeStats::removed_handles; a real tunnel sampled by three points around is cut too).
   * 0 disables both. */
  std::size_t fill_hole_edges = 2000;
  /** Close the surface into a watertight one for closed objects: after the steps above, every
   * remaining boundary loop, whatever its size, is sealed by ear clipping (shortest chord first,
   * never an edge the mesh already has). An open surface gets closed too. */
  bool watertight = false;
  /** With the scan the samples were simplified from (`support` of coconeReconstruct): tunnels the
   * walk capped are opened. Two facing patches of the mesh that span empty space (no scan point
   * near them) are replaced by a band between their borders whose every triangle lies near the
   * scan: a bolt hole sampled by a few points around, which the cocones alone close on both
   * faces of the part (kTunnelEmptyRadius and below). No effect without `support`. Off by
   * default: it reads every scan point (the pinion's 150,000 simplified to 3%: 43-45 ms instead
   * of 38-40, more than Advancing Front's time on the same points). */
  bool open_tunnels = false;
  /** Components (after extraction) with fewer triangles are dropped; so is a closed component of at
   * most 1% of the largest one's triangles whose every vertex lies within half its local spacing of the
   * largest one (a second layer over that surface, CoconeStats::dropped_layers). */
  std::size_t min_component_triangles = 10;

  /** \brief Empty when valid, else what is wrong. */
  std::string validate() const;
};

/** \brief What happened, step by step. Times in seconds. */
struct CoconeStats
{
  std::size_t input_points = 0;
  std::size_t non_finite_points = 0;
  std::size_t duplicate_points = 0;  ///< points at the same position as an earlier one (not used)
  std::size_t vertices = 0;          ///< distinct points triangulated
  std::size_t delaunay_cells = 0;    ///< finite tetrahedra
  std::size_t hull_vertices = 0;
  std::size_t boundary_samples = 0;  ///< samples that failed the ratio / normal conditions
  std::size_t gap_triangles = 0;     ///< cocone triangles refused as spanning a gap (max_edge_ratio)
  std::size_t apart_triangles = 0;   ///< cocone triangles refused as joining balls far apart (kApartBallRatio)
  std::size_t candidate_triangles = 0;
  std::size_t pruned_triangles = 0;
  std::size_t extracted_triangles = 0;
  std::size_t cleanup_removed_triangles = 0;
  std::size_t filled_triangles = 0;  ///< candidates added afterwards to close notches and small holes
  std::size_t reoriented_pieces = 0;  ///< pieces after the first reversed to agree with the surface around them
  std::size_t stitched_loops = 0;     ///< pairs of facing boundary loops joined by a band
  std::size_t stitched_triangles = 0; ///< triangles of those bands
  std::size_t narrowed_loops = 0;     ///< holes closed but for a gap of at most 8 vertices wider than the guard
  std::size_t removed_handles = 0;    ///< small handles cut out: cycles of three edges around them (the clean-up, step 7)
  std::size_t flipped_edges = 0;      ///< edges flipped to bend the surface less (the clean-up, step 7)
  std::size_t components = 0;
  std::size_t dropped_layers = 0;  ///< small pieces dropped as second layers over the largest one
  std::size_t sealed_loops = 0;  ///< boundary loops sealed by the watertight option
  std::size_t opened_tunnels = 0;   ///< pairs of capping patches replaced by a band (open_tunnels)
  std::size_t tunnel_triangles = 0; ///< triangles of those bands
  std::size_t triangles = 0;       ///< in the output
  std::size_t used_vertices = 0;   ///< distinct vertices referenced by the output
  double time_delaunay = 0, time_poles = 0, time_cocone = 0, time_prune = 0, time_extract = 0,
         time_cleanup = 0, time_total = 0;
};

/** \brief The result: triangles index the input array (so duplicates and non-finite points are
 * simply not referenced). `error` is non-empty when nothing could be built. */
struct CoconeResult
{
  std::vector<Triangle> triangles;
  CoconeStats stats;
  std::string error;
  bool ok() const { return error.empty(); }
};

/** \brief With each sample's ball radius known (sample_radius of coconeReconstruct), a candidate
 * triangle with an edge longer than this many times the sum of its ends' radii is refused: the two
 * balls are far from overlapping, so the samples are not neighbours on the surface (a simplified
 * cloud's representative lies within half its radius of its ball's centre: two overlapping balls
 * put theirs at most 1.5 × the sum apart). Such edges cross the gaps between a gear's teeth or
 * join a thin part's two sides, which the cocones alone accept where the sampling is sparse. The
 * hole filling is not bound by it. Chosen on the shared shapes with a reference mesh at the
 * defaults, 10% and 3% kept (33 runs; the area-weighted distance of the mesh to the reference,
 * with the radii ÷ without): 2 gives 0.94 on the geometric mean (pinion at 10% 0.64, camelhead at
 * 10% 0.40, the worst the turbine at the defaults 1.22) and more boundary edges on 5 runs; 1.5
 * gives 0.98 with 5 runs worse by more than 2% (the fandisk at the defaults 3.9: three refused
 * triangles turn the walk, and the hole filling closes the rest with a triangle of 0.36 L); 2.5
 * gives 0.93, worst 1.22, and 3.5 0.99. Bound by it too, the hole filling leaves holes where it
 * closed them (boundary edges on 23 of the 33 runs). On the closed shapes at 10% and 3%
 * (bench/bench_surface --closed) 2 gives the mean distance within Advancing Front's on 14 runs
 * (12 without radii). Those figures were measured with the points of radius 0 left unknown.
 *
 * A point of radius 0 (a feature point, a point the gap bound or the target size kept as it is) is
 * judged by the radius of its nearest neighbour that has one (among the samples it shares a
 * triangle with that some cocone accepts): left unknown, such points joined feature points across
 * a gear (the pinion at 3%: triangles of 0.23 L, 10 × the median edge). On the same 33 runs this
 * brings the meshes to 0.935 × the distance they had with those points unknown (geometric mean; the
 * pinion at 3% 0.45, the fandisk at the defaults 0.56 and at 3% 0.65, the spool at 10% 0.90; the
 * worst the bunny at 10%, 1.02), the Euler characteristic nearer the reference's on 8 of the 11
 * runs whose χ it changes (farther on 2), and more boundary edges on 7 runs (the fandisk at the
 * defaults 0 → 307 in one loop the hole filling leaves, the pinion at 10% 119 → 368), fewer on 5. */
constexpr double kApartBallRatio = 2.0;

/** \brief The scan a simplified cloud was made from: where the surface is (coconeReconstruct's
 * `support`, CoconeParameters::open_tunnels). */
struct ScanSupport
{
  /// The scan's points; non-finite ones are skipped.
  std::vector<Eigen::Vector3f> points;
  /// Per scan point, the index of the sample standing for it (Result::input_to_output of the
  /// simplification; −1: none). Empty: each scan point is given to its nearest sample (within two
  /// median candidate edges; farther, to none).
  std::vector<std::int64_t> sample_of;
  bool empty() const { return points.empty(); }
};

/** \brief Tunnels (CoconeParameters::open_tunnels) are judged against the spacing of the scan over
 * the surface, h = sqrt(mesh area / scan points) (on the shared scans the median distance of a
 * scan point to its 8 nearest is 1.09-1.21 h). A mesh triangle spans empty space when one of seven
 * of its points (its centroid, the points of barycentric weights (2/3, 1/6, 1/6), the edges'
 * midpoints) is farther than kTunnelEmptyRadius × h from every scan point of its three samples
 * and of their neighbours in the candidate triangles (a capped bore's wall samples, which no mesh
 * triangle holds). From such a triangle a patch grows across edges through the triangles with a
 * point farther than kTunnelPatchRadius × h (at most 64 triangles, bounded by one simple loop of
 * at most 40 edges). Two patches are a bore's caps when their radii are within 3 × of each other,
 * their centres closer than twice the sum of their radii and the line between the centres within
 * 45.6° of both normals, running inwards from each. Nearest pairs first, both are replaced by the
 * band between their borders of least total squared chord length whose triangles have every such
 * point within kTunnelBandRadius × h of the scan (chords new to the mesh, every edge between two
 * triangles); a pair no band joins is left as it was. The Euler characteristic falls by 2 a band.
 * Chosen on the closed shapes of bench_surface --closed --tunnels (10% and 3% kept): the turbine's
 * ten bolt holes, capped on both faces of its flange, open at 10% (at 3%, 9 of 10); the other 18
 * meshes are the ones without (docs/SURFACE.md, step 7). */
constexpr double kTunnelEmptyRadius = 2.0;
constexpr double kTunnelPatchRadius = 1.2;
constexpr double kTunnelBandRadius = 3.0;

/** \brief Reconstruct the surface through `points`. Never throws on bad geometry: fewer than four
 * distinct points, or points spanning no volume (coplanar, collinear), give an empty result with
 * `error` set.
 *
 * `sample_radius`, optional: per point, the radius of the ball it stands for (a simplified cloud:
 * Result::balls, pointRadii); 0 for a point kept as it is (a feature point, a gap point), which is
 * judged by its nearest neighbour's ball (kApartBallRatio); not finite where unknown. Candidate
 * triangles joining two balls far from overlapping are refused (kApartBallRatio,
 * CoconeStats::apart_triangles). Empty: no radius known. Its size must match
 * `points` (else the result is empty with `error` set).
 *
 * `support`, optional: the scan `points` were simplified from, the evidence of where the surface
 * is: tunnels the walk capped are opened (CoconeParameters::open_tunnels, kTunnelEmptyRadius).
 * Empty: the samples alone. A `sample_of` whose size differs from the scan's, or that names no
 * sample, gives an empty result with `error` set. */
CoconeResult coconeReconstruct(const std::vector<Eigen::Vector3d>& points,
                               const CoconeParameters& params = CoconeParameters(),
                               const std::vector<double>& sample_radius = {},
                               const ScanSupport& support = {});

// ---- building blocks (exposed for tests) -------------------------------------------------------

/** \brief Circumcentre of the tetrahedron abcd; false when it is flat to double precision or the
 * result is not finite. */
bool circumcenter(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                  const Eigen::Vector3d& d, Eigen::Vector3d& out);

/** \brief How a Voronoi edge meets the cocone of sample p with unit axis `axis`. */
struct CoconeHit
{
  bool hit = false;
  /** Largest distance from p of the part of the edge inside the cocone (infinity for a ray that
   * stays in it); 0 when there is no hit. */
  double radius = 0;
};

/** \brief The Voronoi edge from `start` to `end` (a segment) or, when `is_ray`, from `start` along
 * the direction `end`, against the cocone {y : |cos∠(y − p, axis)| ≤ cos_limit}. */
CoconeHit coconeIntersect(const Eigen::Vector3d& p, const Eigen::Vector3d& axis, double cos_limit,
                          const Eigen::Vector3d& start, const Eigen::Vector3d& end, bool is_ray);

/** \brief Topology of a triangle mesh over `num_points` vertices. */
struct MeshTopology
{
  std::size_t triangles = 0;
  std::size_t used_vertices = 0;
  std::size_t edges = 0;
  std::size_t boundary_edges = 0;      ///< edges with one triangle
  std::size_t nonmanifold_edges = 0;   ///< edges with more than two triangles
  std::size_t nonmanifold_vertices = 0;///< used vertices whose star is not one disk / half-disk
  std::size_t boundary_loops = 0;      ///< cycles of boundary edges (components of their graph)
  std::size_t components = 0;          ///< connected components of triangles (through edges)
  std::size_t degenerate_triangles = 0;///< triangles with a repeated vertex
  bool consistently_oriented = true;   ///< every two-triangle edge is used once in each direction
  long euler_characteristic = 0;       ///< V_used − E + F
  bool isClosedManifold() const
  {
    return triangles > 0 && boundary_edges == 0 && nonmanifold_edges == 0 && nonmanifold_vertices == 0 &&
           degenerate_triangles == 0 && consistently_oriented;
  }
  bool isManifold() const
  {
    return nonmanifold_edges == 0 && nonmanifold_vertices == 0 && degenerate_triangles == 0;
  }
};

MeshTopology analyzeTopology(std::size_t num_points, const std::vector<Triangle>& triangles);

}  // namespace surface
}  // namespace pcl_ecs
