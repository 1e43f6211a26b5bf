// mesh_io.h — triangle mesh writers (PLY binary, OBJ, legacy VTK), chosen by the file extension.
#pragma once

#include <pcl_ecs/surface/cocone.h>

#include <Eigen/Core>

#include <cstdint>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

namespace pcl_ecs
{
namespace surface
{

enum class MeshFormat
{
  Ply,
  Obj,
  Vtk
};

/** \brief The format named by `path`'s extension (.ply, .obj, .vtk; any case). Throws
 * std::invalid_argument naming the extensions understood. */
MeshFormat meshFormatFromPath(const std::string& path);

/** \brief A mesh with only the vertices its triangles use: `vertices[k]` is input point
 * `source_index[k]`, and `triangles` index `vertices`. */
struct CompactMesh
{
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::uint32_t> source_index;
  std::vector<Triangle> triangles;
};

/** \brief Keep the used vertices of (points, triangles), in increasing input order. */
CompactMesh compactMesh(const std::vector<Eigen::Vector3d>& points, const std::vector<Triangle>& triangles);

/** \brief Optional per-vertex colour (same length as the vertices), written to PLY and VTK. */
struct VertexColors
{
  std::vector<std::array<std::uint8_t, 3>> rgb;
};

/** \brief Write a mesh to a stream. Throws std::runtime_error when the stream fails. */
void writeMesh(std::ostream& out, MeshFormat format, const CompactMesh& mesh, const VertexColors* colors = nullptr);

}  // namespace surface
}  // namespace pcl_ecs
