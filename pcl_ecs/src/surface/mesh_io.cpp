// mesh_io.cpp — see mesh_io.h.
#include <pcl_ecs/surface/mesh_io.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <iomanip>
#include <limits>

namespace pcl_ecs
{
namespace surface
{
namespace
{
template <typename T>
void putLE(std::ostream& out, T value)
{
  static_assert(std::is_trivially_copyable<T>::value, "plain values only");
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  // Hosts we build on are little-endian (x86-64, aarch64); PLY's header says so.
  out.write(bytes, sizeof(T));
}
}  // namespace

MeshFormat meshFormatFromPath(const std::string& path)
{
  const auto dot = path.find_last_of('.');
  std::string ext = dot == std::string::npos ? std::string() : path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == "ply")
    return MeshFormat::Ply;
  if (ext == "obj")
    return MeshFormat::Obj;
  if (ext == "vtk")
    return MeshFormat::Vtk;
  throw std::invalid_argument(path + ": unknown mesh format '" + ext +
                              "' (the extension must be .ply, .obj or .vtk)");
}

CompactMesh compactMesh(const std::vector<Eigen::Vector3d>& points, const std::vector<Triangle>& triangles)
{
  CompactMesh m;
  constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> remap(points.size(), none);
  for (const Triangle& t : triangles)
    for (std::uint32_t x : t)
      remap.at(x) = 0;
  for (std::uint32_t i = 0; i < points.size(); ++i)
    if (remap[i] != none)
    {
      remap[i] = static_cast<std::uint32_t>(m.vertices.size());
      m.vertices.push_back(points[i]);
      m.source_index.push_back(i);
    }
  m.triangles.reserve(triangles.size());
  for (const Triangle& t : triangles)
    m.triangles.push_back({remap[t[0]], remap[t[1]], remap[t[2]]});
  return m;
}

void writeMesh(std::ostream& out, MeshFormat format, const CompactMesh& mesh, const VertexColors* colors)
{
  const bool rgb = colors && colors->rgb.size() == mesh.vertices.size();
  switch (format)
  {
  case MeshFormat::Ply:
  {
    out << "ply\nformat binary_little_endian 1.0\ncomment pcl_ecs Cocone\n"
        << "element vertex " << mesh.vertices.size() << "\nproperty double x\nproperty double y\nproperty double z\n";
    if (rgb)
      out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    out << "element face " << mesh.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
    for (std::size_t i = 0; i < mesh.vertices.size(); ++i)
    {
      for (int k = 0; k < 3; ++k)
        putLE<double>(out, mesh.vertices[i][k]);
      if (rgb)
        out.write(reinterpret_cast<const char*>(colors->rgb[i].data()), 3);
    }
    for (const Triangle& t : mesh.triangles)
    {
      putLE<std::uint8_t>(out, 3);
      for (std::uint32_t x : t)
        putLE<std::int32_t>(out, static_cast<std::int32_t>(x));
    }
    break;
  }
  case MeshFormat::Obj:
  {
    out << "# pcl_ecs Cocone: " << mesh.vertices.size() << " vertices, " << mesh.triangles.size() << " triangles\n";
    out << std::setprecision(17);
    for (const auto& v : mesh.vertices)
      out << "v " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    for (const Triangle& t : mesh.triangles)
      out << "f " << t[0] + 1 << ' ' << t[1] + 1 << ' ' << t[2] + 1 << '\n';
    break;
  }
  case MeshFormat::Vtk:
  {
    out << "# vtk DataFile Version 3.0\npcl_ecs Cocone\nASCII\nDATASET POLYDATA\n";
    out << std::setprecision(17);
    out << "POINTS " << mesh.vertices.size() << " double\n";
    for (const auto& v : mesh.vertices)
      out << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
    out << "POLYGONS " << mesh.triangles.size() << ' ' << mesh.triangles.size() * 4 << '\n';
    for (const Triangle& t : mesh.triangles)
      out << "3 " << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
    if (rgb)
    {
      out << "POINT_DATA " << mesh.vertices.size() << "\nCOLOR_SCALARS rgb 3\n";
      for (const auto& c : colors->rgb)
        out << c[0] / 255.0 << ' ' << c[1] / 255.0 << ' ' << c[2] / 255.0 << '\n';
    }
    break;
  }
  }
  out.flush();
  if (!out)
    throw std::runtime_error("writing the mesh failed (disk full or the file went away?)");
}

}  // namespace surface
}  // namespace pcl_ecs
