// quality_metrics.h — how well a simplified cloud stands for its original (issue 4's metrics).
// Every distance is relative to L, the diagonal of the original's bounding box.
#pragma once

#include <Eigen/Core>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstddef>
#include <vector>

namespace pcl_ecs
{
namespace eval
{

/** \brief A triangle mesh: vertices and index triples. */
struct TriangleMesh
{
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> triangles;
};

/** \brief The metrics; distances are fractions of L. */
struct QualityMetrics
{
  double bbox_diagonal = 0;     ///< L (input units)
  std::size_t original_points = 0, simplified_points = 0;
  double surface_rms = 0;       ///< per original point: distance to the plane of its 8 nearest simplified points
  double surface_p99 = 0;
  double coverage_mean = 0;     ///< per original point: distance to the nearest simplified point
  double coverage_max = 0;
  double tangent_rms = 0;       ///< per original point: offset of its nearest simplified point along the original
  double tangent_p99 = 0;       ///<   point's normal (PCA of its 16 nearest original points)
  double hausdorff = 0;         ///< symmetric Hausdorff distance between the two clouds
  bool has_mesh = false;
  double mesh_mean = 0;         ///< per simplified point: distance to the reference mesh
  double mesh_p99 = 0;
  double mesh_max = 0;
  std::size_t sharp_edge_samples = 0;
  double edge_mean = 0;         ///< per sample on a sharp mesh edge: distance to the nearest simplified point
  double edge_p90 = 0;
};

/** \brief Compute the metrics. `mesh` may be null. `sharp_angle_deg`: dihedral angle (between
 * face normals) above which a mesh edge is sharp; samples are spaced `edge_spacing` × L apart.
 * Returns false (and leaves `out` zero) when either cloud is empty. */
bool evaluateQuality(const pcl::PointCloud<pcl::PointXYZ>& original,
                     const pcl::PointCloud<pcl::PointXYZ>& simplified, const TriangleMesh* mesh,
                     QualityMetrics& out, double sharp_angle_deg = 40.0, double edge_spacing = 5e-4);

/** \brief Points sampled every `spacing` along the mesh edges whose adjacent faces' normals differ
 * by more than `angle_deg` (edges with one face are not sharp: they are borders). */
std::vector<Eigen::Vector3d> sampleSharpEdges(const TriangleMesh& mesh, double angle_deg, double spacing);

/** \brief Distance between two triangle meshes, as fractions of L (the diagonal of the bounding
 * box of `reference`). Each surface is sampled (its vertices, plus `samples_per_triangle` points at
 * fixed barycentric positions in every triangle) and the samples' distances to the other surface
 * are measured with an AABB tree. */
struct MeshDistance
{
  double bbox_diagonal = 0;
  double to_reference_mean = 0, to_reference_max = 0;  ///< from `mesh` to `reference`
  double from_reference_mean = 0, from_reference_max = 0;  ///< from `reference` to `mesh`
  double hausdorff() const { return to_reference_max > from_reference_max ? to_reference_max : from_reference_max; }
};

/** \brief See MeshDistance; false when either mesh has no triangle. */
bool meshDistance(const TriangleMesh& mesh, const TriangleMesh& reference, MeshDistance& out,
                  int samples_per_triangle = 3);

}  // namespace eval
}  // namespace pcl_ecs
