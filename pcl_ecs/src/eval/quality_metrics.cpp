#include <pcl_ecs/eval/quality_metrics.h>

#include <pcl_ecs/search/nanoflann_search.h>

#include <algorithm>
#include <cmath>
#include <map>

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>
#include <Eigen/Eigenvalues>

namespace pcl_ecs
{
namespace eval
{

namespace
{
double percentile(std::vector<double> v, double p)
{
  if (v.empty())
    return 0.0;
  const std::size_t k = std::min(v.size() - 1, static_cast<std::size_t>(std::floor(p * (v.size() - 1) + 0.5)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

double mean(const std::vector<double>& v)
{
  double s = 0.0;
  for (double x : v)
    s += x;
  return v.empty() ? 0.0 : s / static_cast<double>(v.size());
}

double rms(const std::vector<double>& v)
{
  double s = 0.0;
  for (double x : v)
    s += x * x;
  return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
}

/// A search over `cloud` in a frame centred at `origin` (float precision for large coordinates).
struct Index
{
  Index(const pcl::PointCloud<pcl::PointXYZ>& cloud, const Eigen::Vector3d& o) : origin(o)
  {
    local = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
    for (const auto& p : cloud)
      local->push_back(toLocal(p.getVector3fMap().cast<double>()));
    search.setInputCloud(local);
  }
  pcl::PointXYZ toLocal(const Eigen::Vector3d& p) const
  {
    const Eigen::Vector3d q = p - origin;
    return pcl::PointXYZ(static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()));
  }
  double nearest(const Eigen::Vector3d& p) const
  {
    pcl::Indices i;
    std::vector<float> d2;
    return search.nearestKSearch(toLocal(p), 1, i, d2) == 1 ? std::sqrt(static_cast<double>(d2[0])) : 0.0;
  }
  Eigen::Vector3d origin;
  pcl::PointCloud<pcl::PointXYZ>::Ptr local;
  NanoflannSearch search;
};

/// The least-squares plane of some points: their centroid and the least-variance direction.
struct Plane
{
  Eigen::Vector3d centroid, normal;
};

Plane fitPlane(const pcl::PointCloud<pcl::PointXYZ>& cloud, const pcl::Indices& idx)
{
  Plane plane;
  plane.centroid = Eigen::Vector3d::Zero();
  for (const int j : idx)
    plane.centroid += cloud[static_cast<std::size_t>(j)].getVector3fMap().cast<double>();
  plane.centroid /= static_cast<double>(idx.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const int j : idx)
  {
    const Eigen::Vector3d d = cloud[static_cast<std::size_t>(j)].getVector3fMap().cast<double>() - plane.centroid;
    cov += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  plane.normal = es.eigenvectors().col(0);
  return plane;
}

/// |n · (q − p)|: the offset of `q` (local frame of `orig`) from the original point `p` along p's
/// normal, the least-variance direction of p's `k` nearest original points. Below 3 neighbours
/// there is no normal and the whole distance counts.
double tangentOffset(const Index& orig, const Eigen::Vector3d& p, const Eigen::Vector3d& q, int k)
{
  const Eigen::Vector3d pl = orig.toLocal(p).getVector3fMap().cast<double>();
  pcl::Indices idx;
  std::vector<float> d2;
  orig.search.nearestKSearch(orig.toLocal(p), k, idx, d2);
  if (idx.size() < 3)
    return (q - pl).norm();
  return std::abs((q - pl).dot(fitPlane(*orig.local, idx).normal));
}
}  // namespace

std::vector<Eigen::Vector3d> sampleSharpEdges(const TriangleMesh& mesh, double angle_deg, double spacing)
{
  std::map<std::pair<int, int>, std::vector<int>> faces_of_edge;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
    for (int k = 0; k < 3; ++k)
    {
      int a = mesh.triangles[f][k], b = mesh.triangles[f][(k + 1) % 3];
      if (a > b)
        std::swap(a, b);
      faces_of_edge[{a, b}].push_back(static_cast<int>(f));
    }
  auto normal = [&](int f) {
    const auto& t = mesh.triangles[static_cast<std::size_t>(f)];
    return (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]).normalized();
  };
  const double cos_limit = std::cos(angle_deg * M_PI / 180.0);
  std::vector<Eigen::Vector3d> samples;
  for (const auto& [edge, faces] : faces_of_edge)
  {
    if (faces.size() != 2)
      continue;
    if (normal(faces[0]).dot(normal(faces[1])) >= cos_limit)
      continue;  // the normals differ by less than the angle: a smooth edge
    const Eigen::Vector3d a = mesh.vertices[static_cast<std::size_t>(edge.first)];
    const Eigen::Vector3d b = mesh.vertices[static_cast<std::size_t>(edge.second)];
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / spacing)));
    for (int i = 0; i < n; ++i)  // the far end belongs to the next edge
      samples.push_back(a + (b - a) * (static_cast<double>(i) / n));
  }
  return samples;
}

bool evaluateQuality(const pcl::PointCloud<pcl::PointXYZ>& original,
                     const pcl::PointCloud<pcl::PointXYZ>& simplified, const TriangleMesh* mesh,
                     QualityMetrics& out, double sharp_angle_deg, double edge_spacing)
{
  out = QualityMetrics{};
  if (original.empty() || simplified.empty())
    return false;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const auto& p : original)
  {
    lo = lo.cwiseMin(p.getVector3fMap().cast<double>());
    hi = hi.cwiseMax(p.getVector3fMap().cast<double>());
  }
  const double L = (hi - lo).norm();
  if (!(L > 0.0))
    return false;
  const Eigen::Vector3d origin = 0.5 * (lo + hi);
  out.bbox_diagonal = L;
  out.original_points = original.size();
  out.simplified_points = simplified.size();
  const Index simp(simplified, origin), orig(original, origin);

  // Surface deviation, coverage and tangent offset, per original point.
  std::vector<double> deviation(original.size()), cover(original.size()), tangent(original.size());
  const int k = static_cast<int>(std::min<std::size_t>(8, simplified.size()));
  const int k_normal = static_cast<int>(std::min<std::size_t>(16, original.size()));
#pragma omp parallel for schedule(dynamic, 1024)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(original.size()); ++i)
  {
    const Eigen::Vector3d p = original[static_cast<std::size_t>(i)].getVector3fMap().cast<double>();
    pcl::Indices idx;
    std::vector<float> d2;
    simp.search.nearestKSearch(simp.toLocal(p), k, idx, d2);
    cover[static_cast<std::size_t>(i)] = std::sqrt(static_cast<double>(d2[0])) / L;
    const Eigen::Vector3d nearest_out = (*simp.local)[static_cast<std::size_t>(idx[0])].getVector3fMap().cast<double>();
    tangent[static_cast<std::size_t>(i)] = tangentOffset(orig, p, nearest_out, k_normal) / L;
    const Plane plane = fitPlane(*simp.local, idx);
    const Eigen::Vector3d offset = simp.toLocal(p).getVector3fMap().cast<double>() - plane.centroid;
    const double dev = idx.size() >= 3 ? std::abs(offset.dot(plane.normal)) : offset.norm();
    deviation[static_cast<std::size_t>(i)] = dev / L;
  }
  out.surface_rms = rms(deviation);
  out.surface_p99 = percentile(deviation, 0.99);
  out.coverage_mean = mean(cover);
  out.coverage_max = *std::max_element(cover.begin(), cover.end());
  out.tangent_rms = rms(tangent);
  out.tangent_p99 = percentile(tangent, 0.99);
  double back = 0.0;
  for (const auto& s : simplified)
    back = std::max(back, orig.nearest(s.getVector3fMap().cast<double>()) / L);
  out.hausdorff = std::max(out.coverage_max, back);

  if (mesh && !mesh->triangles.empty())
  {
    using K = CGAL::Simple_cartesian<double>;
    using Triangle = K::Triangle_3;
    using Primitive = CGAL::AABB_triangle_primitive<K, std::vector<Triangle>::iterator>;
    using Tree = CGAL::AABB_tree<CGAL::AABB_traits<K, Primitive>>;
    std::vector<Triangle> tris;
    tris.reserve(mesh->triangles.size());
    auto P = [&](int v) {
      const Eigen::Vector3d q = mesh->vertices[static_cast<std::size_t>(v)] - origin;
      return K::Point_3(q.x(), q.y(), q.z());
    };
    for (const auto& t : mesh->triangles)
      tris.emplace_back(P(t[0]), P(t[1]), P(t[2]));
    Tree tree(tris.begin(), tris.end());
    tree.accelerate_distance_queries();
    std::vector<double> to_mesh;
    to_mesh.reserve(simplified.size());
    for (const auto& s : simplified)
    {
      const Eigen::Vector3d q = s.getVector3fMap().cast<double>() - origin;
      to_mesh.push_back(std::sqrt(tree.squared_distance(K::Point_3(q.x(), q.y(), q.z()))) / L);
    }
    out.has_mesh = true;
    out.mesh_mean = mean(to_mesh);
    out.mesh_p99 = percentile(to_mesh, 0.99);
    out.mesh_max = *std::max_element(to_mesh.begin(), to_mesh.end());
    const auto samples = sampleSharpEdges(*mesh, sharp_angle_deg, edge_spacing * L);
    std::vector<double> edge;
    edge.reserve(samples.size());
    for (const auto& e : samples)
      edge.push_back(simp.nearest(e) / L);
    out.sharp_edge_samples = samples.size();
    out.edge_mean = mean(edge);
    out.edge_p90 = percentile(edge, 0.90);
  }
  return true;
}

namespace
{
using MK = CGAL::Simple_cartesian<double>;
using MTri = MK::Triangle_3;
using MPrimitive = CGAL::AABB_triangle_primitive<MK, std::vector<MTri>::iterator>;
using MTree = CGAL::AABB_tree<CGAL::AABB_traits<MK, MPrimitive>>;

std::vector<MTri> cgalTriangles(const TriangleMesh& m, const Eigen::Vector3d& origin)
{
  std::vector<MTri> tris;
  tris.reserve(m.triangles.size());
  auto P = [&](int v) {
    const Eigen::Vector3d q = m.vertices[static_cast<std::size_t>(v)] - origin;
    return MK::Point_3(q.x(), q.y(), q.z());
  };
  for (const auto& t : m.triangles)
    tris.emplace_back(P(t[0]), P(t[1]), P(t[2]));
  return tris;
}

std::vector<Eigen::Vector3d> surfaceSamples(const TriangleMesh& m, int per_triangle)
{
  std::vector<Eigen::Vector3d> s(m.vertices.begin(), m.vertices.end());
  // Fixed barycentric positions: the centroid, then points towards each vertex.
  static const double bary[][3] = {{1.0 / 3, 1.0 / 3, 1.0 / 3}, {2.0 / 3, 1.0 / 6, 1.0 / 6},
                                   {1.0 / 6, 2.0 / 3, 1.0 / 6}, {1.0 / 6, 1.0 / 6, 2.0 / 3}};
  const int k = std::max(0, std::min(per_triangle, 4));
  for (const auto& t : m.triangles)
    for (int j = 0; j < k; ++j)
      s.push_back(bary[j][0] * m.vertices[static_cast<std::size_t>(t[0])] +
                  bary[j][1] * m.vertices[static_cast<std::size_t>(t[1])] +
                  bary[j][2] * m.vertices[static_cast<std::size_t>(t[2])]);
  return s;
}

void oneWay(const std::vector<Eigen::Vector3d>& samples, const MTree& tree, const Eigen::Vector3d& origin,
            double L, double& mean_out, double& max_out)
{
  std::vector<double> d(samples.size());
#pragma omp parallel for schedule(static)
  for (std::ptrdiff_t i = 0; i < static_cast<std::ptrdiff_t>(samples.size()); ++i)
  {
    const Eigen::Vector3d q = samples[static_cast<std::size_t>(i)] - origin;
    d[static_cast<std::size_t>(i)] = std::sqrt(tree.squared_distance(MK::Point_3(q.x(), q.y(), q.z()))) / L;
  }
  mean_out = mean(d);
  max_out = d.empty() ? 0.0 : *std::max_element(d.begin(), d.end());
}
}  // namespace

bool meshDistance(const TriangleMesh& mesh, const TriangleMesh& reference, MeshDistance& out, int samples_per_triangle)
{
  out = MeshDistance{};
  if (mesh.triangles.empty() || reference.triangles.empty())
    return false;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (const auto& v : reference.vertices)
  {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  const double L = (hi - lo).norm();
  if (!(L > 0))
    return false;
  const Eigen::Vector3d origin = 0.5 * (lo + hi);
  out.bbox_diagonal = L;
  auto ref_tris = cgalTriangles(reference, origin);
  auto mesh_tris = cgalTriangles(mesh, origin);
  MTree ref_tree(ref_tris.begin(), ref_tris.end()), mesh_tree(mesh_tris.begin(), mesh_tris.end());
  ref_tree.accelerate_distance_queries();
  mesh_tree.accelerate_distance_queries();
  oneWay(surfaceSamples(mesh, samples_per_triangle), ref_tree, origin, L, out.to_reference_mean, out.to_reference_max);
  oneWay(surfaceSamples(reference, samples_per_triangle), mesh_tree, origin, L, out.from_reference_mean,
         out.from_reference_max);
  return true;
}

}  // namespace eval
}  // namespace pcl_ecs
