// Cocone: building blocks on exact cases, then the surfaces of analytic shapes and a real scan.
#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/surface/cocone.h>

#include "synthetic_shapes.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <set>
#include <unordered_map>
#ifdef _OPENMP
#include <omp.h>
#endif

using pcl_ecs::surface::analyzeTopology;
using pcl_ecs::surface::CoconeParameters;
using pcl_ecs::surface::coconeReconstruct;
using pcl_ecs::surface::MeshTopology;
using pcl_ecs::surface::Triangle;
using pcl_ecs_test::Rng;

namespace
{
std::vector<Eigen::Vector3d> randomSphere(std::size_t n, double rho, std::uint64_t seed, double noise = 0.0)
{
  Rng rng(seed);
  std::vector<Eigen::Vector3d> pts;
  while (pts.size() < n)
  {
    Eigen::Vector3d d(rng.normal(), rng.normal(), rng.normal());
    if (d.norm() < 1e-9)
      continue;
    d.normalize();
    pts.push_back((rho + (noise > 0 ? noise * rng.normal() : 0.0)) * d);
  }
  return pts;
}

/** Area-uniform samples of the torus (rejection on the area element R + r cos v). */
std::vector<Eigen::Vector3d> randomTorus(std::size_t n, double R, double r, std::uint64_t seed)
{
  Rng rng(seed);
  std::vector<Eigen::Vector3d> pts;
  while (pts.size() < n)
  {
    const double u = rng.uniform(0, 2 * M_PI), v = rng.uniform(0, 2 * M_PI);
    if (rng.uniform() * (R + r) > R + r * std::cos(v))
      continue;
    pts.emplace_back((R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u), r * std::sin(v));
  }
  return pts;
}

MeshTopology topologyOf(const std::vector<Eigen::Vector3d>& pts, const pcl_ecs::surface::CoconeResult& r)
{
  return analyzeTopology(pts.size(), r.triangles);
}

/** Every triangle's normal points away from the origin (outward on a sphere centred there). */
double outwardFraction(const std::vector<Eigen::Vector3d>& pts, const std::vector<Triangle>& tris)
{
  std::size_t out = 0;
  for (const Triangle& t : tris)
  {
    const Eigen::Vector3d n = (pts[t[1]] - pts[t[0]]).cross(pts[t[2]] - pts[t[0]]);
    const Eigen::Vector3d c = (pts[t[0]] + pts[t[1]] + pts[t[2]]) / 3.0;
    out += n.dot(c) > 0 ? 1 : 0;
  }
  return tris.empty() ? 0.0 : static_cast<double>(out) / static_cast<double>(tris.size());
}
}  // namespace

// ---- building blocks -----------------------------------------------------------------------------

TEST(Circumcenter, RegularTetrahedronAndFlat)
{
  const Eigen::Vector3d a(1, 1, 1), b(1, -1, -1), c(-1, 1, -1), d(-1, -1, 1);
  Eigen::Vector3d o;
  ASSERT_TRUE(pcl_ecs::surface::circumcenter(a, b, c, d, o));
  EXPECT_NEAR(o.norm(), 0.0, 1e-12);
  // Translated: the centre moves with it.
  const Eigen::Vector3d t(3, -2, 5);
  ASSERT_TRUE(pcl_ecs::surface::circumcenter(a + t, b + t, c + t, d + t, o));
  EXPECT_NEAR((o - t).norm(), 0.0, 1e-12);
  // Flat: no centre.
  EXPECT_FALSE(pcl_ecs::surface::circumcenter(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0),
                                              Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(1, 1, 0), o));
}

TEST(CoconeIntersect, SegmentsAgainstTheBand)
{
  using pcl_ecs::surface::coconeIntersect;
  const Eigen::Vector3d p(0, 0, 0), axis(0, 0, 1);
  const double k = std::cos(3 * M_PI / 8);  // 0.3827
  // Both ends above the band (in the upper cone): no hit.
  EXPECT_FALSE(coconeIntersect(p, axis, k, {0.1, 0, 1}, {-0.1, 0, 2}, false).hit);
  // Both ends below: no hit.
  EXPECT_FALSE(coconeIntersect(p, axis, k, {0.1, 0, -1}, {0.2, 0.1, -3}, false).hit);
  // Opposite sides: hit, even though neither end is in the band.
  auto h = coconeIntersect(p, axis, k, {0.1, 0, 1}, {0.1, 0, -1}, false);
  EXPECT_TRUE(h.hit);
  // The part in the band is where |z| ≤ k·|(0.1, z)|: its farthest point is at the band's edge.
  const double zb = 0.1 * k / std::sqrt(1 - k * k);
  EXPECT_NEAR(h.radius, std::sqrt(0.01 + zb * zb), 1e-12);
  // An end inside the band at distance 2: radius 2.
  h = coconeIntersect(p, axis, k, {2, 0, 0.1}, {0.1, 0, 1}, false);
  EXPECT_TRUE(h.hit);
  EXPECT_NEAR(h.radius, std::sqrt(4.01), 1e-12);
  // Exactly on the boundary angle (|cos| = k): counts as inside.
  const double s = std::sqrt(1 - k * k);
  EXPECT_TRUE(coconeIntersect(p, axis, k, {s, 0, k}, {s, 0, 2}, false).hit);
  // A ray along the axis from above: no hit; a horizontal ray: hit, unbounded.
  EXPECT_FALSE(coconeIntersect(p, axis, k, {0, 0, 1}, {0, 0, 1}, true).hit);
  h = coconeIntersect(p, axis, k, {0, 0, 1}, {1, 0, 0}, true);
  EXPECT_TRUE(h.hit);
  EXPECT_TRUE(std::isinf(h.radius));
  // A ray from below the band going up: crosses it; bounded radius.
  h = coconeIntersect(p, axis, k, {0.5, 0, -2}, {0, 0, 1}, true);
  EXPECT_TRUE(h.hit);
  EXPECT_TRUE(std::isfinite(h.radius));
  // A ray from below going down: no hit.
  EXPECT_FALSE(coconeIntersect(p, axis, k, {0.5, 0, -2}, {0, 0, -1}, true).hit);
}

TEST(Topology, TetrahedronAndOpenFan)
{
  // A consistently oriented tetrahedron: closed, χ = 2.
  std::vector<Triangle> tet = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
  MeshTopology t = analyzeTopology(4, tet);
  EXPECT_TRUE(t.isClosedManifold());
  EXPECT_EQ(t.euler_characteristic, 2);
  EXPECT_EQ(t.components, 1u);
  // Flip one triangle: no longer consistently oriented.
  tet[1] = {0, 3, 1};
  EXPECT_FALSE(analyzeTopology(4, tet).consistently_oriented);
  // Remove a face: one boundary loop, χ = 1.
  std::vector<Triangle> open = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}};
  t = analyzeTopology(4, open);
  EXPECT_EQ(t.boundary_edges, 3u);
  EXPECT_EQ(t.boundary_loops, 1u);
  EXPECT_EQ(t.euler_characteristic, 1);
  EXPECT_TRUE(t.isManifold());
  // Two triangles touching at one vertex only: a non-manifold vertex.
  std::vector<Triangle> bowtie = {{0, 1, 2}, {0, 3, 4}};
  t = analyzeTopology(5, bowtie);
  EXPECT_EQ(t.nonmanifold_vertices, 1u);
  // Three triangles on one edge: a non-manifold edge.
  std::vector<Triangle> fin = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  EXPECT_EQ(analyzeTopology(5, fin).nonmanifold_edges, 1u);
}

// ---- surfaces ------------------------------------------------------------------------------------

class CoconeSphere : public ::testing::TestWithParam<std::size_t>
{
};

TEST_P(CoconeSphere, ClosedOrientedManifoldWithEveryVertex)
{
  const std::size_t n = GetParam();
  const auto pts = randomSphere(n, 1.0, 1000 + n);
  const auto r = coconeReconstruct(pts);
  ASSERT_TRUE(r.ok()) << r.error;
  const MeshTopology t = topologyOf(pts, r);
  EXPECT_TRUE(t.isClosedManifold()) << "boundary " << t.boundary_edges << " nm edges " << t.nonmanifold_edges
                                    << " nm vertices " << t.nonmanifold_vertices;
  EXPECT_EQ(t.used_vertices, n);
  EXPECT_EQ(t.triangles, 2 * n - 4);
  EXPECT_EQ(t.components, 1u);
  EXPECT_EQ(t.euler_characteristic, 2);
  EXPECT_DOUBLE_EQ(outwardFraction(pts, r.triangles), 1.0);
}
INSTANTIATE_TEST_SUITE_P(Sizes, CoconeSphere, ::testing::Values(500, 5000, 20000, 100000));

TEST(Cocone, TorusIsClosedWithGenusOne)
{
  const auto pts = randomTorus(20000, 1.0, 0.35, 7);
  const auto r = coconeReconstruct(pts);
  ASSERT_TRUE(r.ok()) << r.error;
  const MeshTopology t = topologyOf(pts, r);
  EXPECT_TRUE(t.isClosedManifold()) << "boundary " << t.boundary_edges << " nm edges " << t.nonmanifold_edges
                                    << " nm vertices " << t.nonmanifold_vertices;
  EXPECT_EQ(t.used_vertices, pts.size());
  EXPECT_EQ(t.triangles, 2 * pts.size());
  EXPECT_EQ(t.euler_characteristic, 0);
  EXPECT_EQ(r.stats.removed_handles, 0u);  // its handle is far more than three samples around
}

TEST(Cocone, CappedSphereKeepsItsOpening)
{
  auto all = randomSphere(12000, 1.0, 11);
  std::vector<Eigen::Vector3d> pts;
  for (const auto& p : all)
    if (p.z() > -0.5)
      pts.push_back(p);
  const auto r = coconeReconstruct(pts);
  ASSERT_TRUE(r.ok()) << r.error;
  const MeshTopology t = topologyOf(pts, r);
  EXPECT_TRUE(t.isManifold()) << "nm edges " << t.nonmanifold_edges << " nm vertices " << t.nonmanifold_vertices;
  EXPECT_TRUE(t.consistently_oriented);
  EXPECT_EQ(t.boundary_loops, 1u);
  EXPECT_EQ(t.euler_characteristic, 1);
  EXPECT_EQ(t.components, 1u);
  // Nothing spans the opening: no triangle lies below the cut.
  for (const Triangle& tri : r.triangles)
    EXPECT_GT((pts[tri[0]] + pts[tri[1]] + pts[tri[2]]).z() / 3.0, -0.5 - 1e-9);
  EXPECT_GE(static_cast<double>(t.used_vertices), 0.98 * static_cast<double>(pts.size()));
}

TEST(Cocone, NoisySphereIsNotEroded)
{
  const std::size_t n = 20000;
  const double spacing = std::sqrt(4 * M_PI / n);
  const auto pts = randomSphere(n, 1.0, 5, 0.07 * spacing);
  const auto r = coconeReconstruct(pts);
  ASSERT_TRUE(r.ok()) << r.error;
  const MeshTopology t = topologyOf(pts, r);
  EXPECT_TRUE(t.isManifold());
  EXPECT_TRUE(t.consistently_oriented);
  EXPECT_GE(static_cast<double>(t.used_vertices), 0.95 * n);
}

TEST(Cocone, DegenerateInputGivesAClearError)
{
  std::vector<Eigen::Vector3d> few = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  auto r = coconeReconstruct(few);
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(r.triangles.empty());
  EXPECT_NE(r.error.find("at least 4"), std::string::npos) << r.error;

  std::vector<Eigen::Vector3d> plane;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j)
      plane.emplace_back(i, j, 0.0);
  r = coconeReconstruct(plane);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.error.find("coplanar"), std::string::npos) << r.error;

  std::vector<Eigen::Vector3d> same(50, Eigen::Vector3d(1, 2, 3));
  r = coconeReconstruct(same);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.error.find("same position"), std::string::npos) << r.error;

  std::vector<Eigen::Vector3d> line;
  for (int i = 0; i < 10; ++i)
    line.emplace_back(i, 2 * i, 3 * i);
  r = coconeReconstruct(line);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.error.find("collinear"), std::string::npos) << r.error;

  std::vector<Eigen::Vector3d> nan(10, Eigen::Vector3d(NAN, 0, 0));
  r = coconeReconstruct(nan);
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.stats.non_finite_points, 10u);

  CoconeParameters bad;
  bad.cocone_angle = 2.0;
  r = coconeReconstruct(randomSphere(100, 1.0, 1), bad);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.error.find("cocone angle"), std::string::npos) << r.error;
}

TEST(Cocone, DuplicatesAreIgnored)
{
  auto pts = randomSphere(2000, 1.0, 3);
  const std::size_t n = pts.size();
  for (std::size_t i = 0; i < 100; ++i)
    pts.push_back(pts[i * 7]);
  const auto r = coconeReconstruct(pts);
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_EQ(r.stats.duplicate_points, 100u);
  const MeshTopology t = topologyOf(pts, r);
  EXPECT_TRUE(t.isClosedManifold());
  EXPECT_EQ(t.used_vertices, n);
  EXPECT_EQ(t.triangles, 2 * n - 4);
  for (const Triangle& tri : r.triangles)
    for (auto x : tri)
      EXPECT_LT(x, n);  // the first copy is the one used
}

TEST(Cocone, DeterministicWhateverTheThreadCount)
{
  const auto pts = randomTorus(5000, 1.0, 0.4, 9);
  const auto a = coconeReconstruct(pts), b = coconeReconstruct(pts);
  EXPECT_EQ(a.triangles, b.triangles);
#ifdef _OPENMP
  const int before = omp_get_max_threads();
  omp_set_num_threads(1);
  const auto one = coconeReconstruct(pts);
  omp_set_num_threads(4);
  const auto four = coconeReconstruct(pts);
  omp_set_num_threads(before);
  EXPECT_EQ(a.triangles, one.triangles);
  EXPECT_EQ(a.triangles, four.triangles);
#endif
}

// ---- the PCL surface class -----------------------------------------------------------------------

#include <pcl_ecs/surface/cocone_reconstruction.h>

#include <pcl/conversions.h>

TEST(CoconePcl, IndicesReferToTheFullCloudAndTheCloudIsCopied)
{
  // A sphere of 3000 points; the mesh is asked for the odd ones only, plus junk at even indices.
  const auto sphere = randomSphere(3000, 2.0, 21);
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZRGB>>();
  auto indices = std::make_shared<pcl::Indices>();
  for (std::size_t i = 0; i < sphere.size(); ++i)
  {
    pcl::PointXYZRGB junk;
    junk.x = junk.y = junk.z = 100.0f;  // far away: would wreck the mesh if used
    cloud->push_back(junk);
    pcl::PointXYZRGB p;
    p.x = static_cast<float>(sphere[i].x());
    p.y = static_cast<float>(sphere[i].y());
    p.z = static_cast<float>(sphere[i].z());
    p.r = 200;
    cloud->push_back(p);
    indices->push_back(static_cast<pcl::index_t>(2 * i + 1));
  }
  pcl_ecs::Cocone<pcl::PointXYZRGB> cocone;
  cocone.setInputCloud(cloud);
  cocone.setIndices(indices);
  pcl::PolygonMesh mesh;
  cocone.reconstruct(mesh);
  ASSERT_TRUE(cocone.getLastError().empty()) << cocone.getLastError();
  EXPECT_EQ(mesh.cloud.width * mesh.cloud.height, cloud->size());
  std::vector<Triangle> tris;
  for (const auto& poly : mesh.polygons)
  {
    ASSERT_EQ(poly.vertices.size(), 3u);
    for (auto v : poly.vertices)
      EXPECT_EQ(v % 2, 1u) << "a point outside the indices was used";
    tris.push_back({static_cast<std::uint32_t>(poly.vertices[0]), static_cast<std::uint32_t>(poly.vertices[1]),
                    static_cast<std::uint32_t>(poly.vertices[2])});
  }
  const MeshTopology t = analyzeTopology(cloud->size(), tris);
  EXPECT_TRUE(t.isClosedManifold());
  EXPECT_EQ(t.used_vertices, sphere.size());
  EXPECT_EQ(t.triangles, 2 * sphere.size() - 4);
  EXPECT_EQ(cocone.getStats().triangles, t.triangles);
}

TEST(CoconeSampleRadii, NoTriangleJoinsTwoBallsThatDoNotOverlap)
{
  // A sphere of 3000 points. Radii far larger than any edge refuse nothing: the same mesh as
  // without radii. Radii of a tenth of the spacing on the northern cap (z > 0.5) and unknown (0)
  // elsewhere: no edge is longer than kApartBallRatio × the sum of its ends' radii (checked by brute
  // force over the result without the hole filling, which the rule does not bind), which leaves
  // few edges between cap points (only pairs of the random sampling closer than 0.4 spacings);
  // the rest of the sphere is meshed as before.
  const auto pts = randomSphere(3000, 1.0, 5);
  const auto plain = coconeReconstruct(pts);
  ASSERT_TRUE(plain.ok()) << plain.error;
  EXPECT_EQ(plain.stats.apart_triangles, 0u);

  const auto large = coconeReconstruct(pts, CoconeParameters(), std::vector<double>(pts.size(), 10.0));
  ASSERT_TRUE(large.ok()) << large.error;
  EXPECT_EQ(large.triangles, plain.triangles);
  EXPECT_EQ(large.stats.apart_triangles, 0u);

  const double spacing = std::sqrt(4 * M_PI / 3000.0);
  std::vector<double> radius(pts.size(), 0.0);
  std::size_t cap = 0;
  for (std::size_t i = 0; i < pts.size(); ++i)
    if (pts[i].z() > 0.5)
    {
      radius[i] = 0.1 * spacing;
      ++cap;
    }
  ASSERT_GT(cap, 500u);
  CoconeParameters no_fill;
  no_fill.fill_hole_edges = 0;
  const auto r = coconeReconstruct(pts, no_fill, radius);
  ASSERT_TRUE(r.ok()) << r.error;
  EXPECT_GT(r.stats.apart_triangles, 0u);
  const auto capEdges = [&](const std::vector<Triangle>& tris) {
    std::set<std::pair<std::uint32_t, std::uint32_t>> e;
    for (const Triangle& t : tris)
      for (int k = 0; k < 3; ++k)
        if (radius[t[k]] > 0 && radius[t[(k + 1) % 3]] > 0)
          e.emplace(std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3]));
    return e;
  };
  const auto without = coconeReconstruct(pts, no_fill);
  std::size_t below = 0, below_plain = 0;
  for (const Triangle& t : r.triangles)
    below += pts[t[0]].z() < 0.3 && pts[t[1]].z() < 0.3 && pts[t[2]].z() < 0.3 ? 1 : 0;
  for (const Triangle& t : without.triangles)
    below_plain += pts[t[0]].z() < 0.3 && pts[t[1]].z() < 0.3 && pts[t[2]].z() < 0.3 ? 1 : 0;
  EXPECT_EQ(below, below_plain);
  const auto kept = capEdges(r.triangles);
  for (const auto& [a, b] : kept)
    EXPECT_LE((pts[a] - pts[b]).norm(), pcl_ecs::surface::kApartBallRatio * (radius[a] + radius[b]))
        << "edge " << a << "-" << b;
  EXPECT_LT(kept.size(), capEdges(without.triangles).size() / 50);
  EXPECT_TRUE(topologyOf(pts, r).isManifold());

  // Radii that do not match the points, or not finite, are refused or ignored (never read past).
  const auto wrong = coconeReconstruct(pts, CoconeParameters(), std::vector<double>(pts.size() - 1, 1.0));
  EXPECT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error.find("sample radii for 2999 points"), std::string::npos) << wrong.error;
  std::vector<double> nan(pts.size(), std::numeric_limits<double>::quiet_NaN());
  const auto unknown = coconeReconstruct(pts, CoconeParameters(), nan);
  ASSERT_TRUE(unknown.ok());
  EXPECT_EQ(unknown.triangles, plain.triangles);
}

TEST(CoconeSampleRadii, CoconeClassTakesThemPerPointOfTheInputCloud)
{
  // The radii are indexed like the input cloud, not like the indices: the odd points form the
  // sphere and carry a tenth of the spacing on the northern cap; the even ones are junk with radii
  // that would refuse nothing. The mesh is the one coconeReconstruct makes from the odd points and
  // their radii. A radius list of another size fails with an error.
  const auto sphere = randomSphere(3000, 1.0, 5);
  const double spacing = std::sqrt(4 * M_PI / 3000.0);
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  auto indices = std::make_shared<pcl::Indices>();
  std::vector<double> radius, sub_radius;
  for (std::size_t i = 0; i < sphere.size(); ++i)
  {
    cloud->push_back(pcl::PointXYZ(100.0f, 100.0f, 100.0f));
    radius.push_back(1e6);
    cloud->push_back(pcl_ecs_test::toPoint(sphere[i]));
    radius.push_back(sphere[i].z() > 0.5 ? 0.1 * spacing : 0.0);
    sub_radius.push_back(radius.back());
    indices->push_back(static_cast<pcl::index_t>(2 * i + 1));
  }
  std::vector<Eigen::Vector3d> sub;
  for (const auto& p : *cloud)
    if (p.x != 100.0f)
      sub.emplace_back(p.x, p.y, p.z);
  const auto expected = coconeReconstruct(sub, CoconeParameters(), sub_radius);
  ASSERT_TRUE(expected.ok());
  ASSERT_GT(expected.stats.apart_triangles, 0u);

  pcl_ecs::Cocone<pcl::PointXYZ> cocone;
  cocone.setInputCloud(cloud);
  cocone.setIndices(indices);
  cocone.setSampleRadii(radius);
  pcl::PolygonMesh mesh;
  cocone.reconstruct(mesh);
  ASSERT_TRUE(cocone.getLastError().empty()) << cocone.getLastError();
  EXPECT_EQ(cocone.getStats().apart_triangles, expected.stats.apart_triangles);
  ASSERT_EQ(mesh.polygons.size(), expected.triangles.size());
  for (std::size_t t = 0; t < expected.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(mesh.polygons[t].vertices[k], 2 * expected.triangles[t][k] + 1);

  cocone.setSampleRadii(std::vector<double>(sphere.size(), 1.0));  // one per index, not per point
  cocone.reconstruct(mesh);
  EXPECT_TRUE(mesh.polygons.empty());
  EXPECT_NE(cocone.getLastError().find("sample radii for 3000 points"), std::string::npos) << cocone.getLastError();
}

TEST(CoconePcl, DegenerateInputGivesAnEmptyMesh)
{
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (int i = 0; i < 20; ++i)
    cloud->push_back(pcl::PointXYZ(static_cast<float>(i), static_cast<float>(i % 5), 0.0f));  // coplanar
  pcl_ecs::Cocone<pcl::PointXYZ> cocone;
  cocone.setInputCloud(cloud);
  pcl::PolygonMesh mesh;
  mesh.polygons.resize(3);  // stale content must go
  cocone.reconstruct(mesh);
  EXPECT_TRUE(mesh.polygons.empty());
  EXPECT_NE(cocone.getLastError().find("coplanar"), std::string::npos);

  // An invalid parameter is refused the same way.
  const auto sphere = randomSphere(200, 1.0, 2);
  cloud->clear();
  for (const auto& p : sphere)
    cloud->push_back(pcl_ecs_test::toPoint(p));
  cocone.setCoconeAngle(-1.0);
  cocone.reconstruct(mesh);
  EXPECT_TRUE(mesh.polygons.empty());
  EXPECT_NE(cocone.getLastError().find("cocone angle"), std::string::npos);
}

// ---- the clean-up step on meshes made by hand -------------------------------------------------------

#include "surface/cocone_detail.h"  // private: the clean-up step alone, the ball-overlap radii

TEST(CoconeSampleRadii, APointKeptAsItIsTakesItsNearestBallsRadius)
{
  // overlapRadii on triangles made by hand: a positive radius is kept; a radius of 0 becomes the
  // radius of the nearest sample it shares a triangle with that has one (a tie at the same
  // distance: the larger); NaN stays unknown (0), and so does a 0 with no such neighbour. The
  // order of the triangles does not matter.
  using pcl_ecs::surface::detail::Facet;
  using pcl_ecs::surface::detail::overlapRadii;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<Eigen::Vector3d> pts = {{0, 0, 0}, {1, 0, 0}, {0, 2, 0},  {5, 5, 5},
                                            {6, 5, 5}, {0, -1, 0}, {0, -3, 0}};
  const std::vector<double> radius = {0.0, 0.5, 3.0, 0.0, nan, 0.7, 0.0};
  auto facet = [](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    return Facet{Triangle{a, b, c}, 7u, {0.f, 0.f, 0.f}};
  };
  std::vector<Facet> facets = {facet(0, 1, 2), facet(0, 5, 6), facet(3, 4, 6)};
  const std::vector<double> expected = {0.7, 0.5, 3.0, 0.0, 0.0, 0.7, 0.7};
  EXPECT_EQ(overlapRadii(pts, facets, radius), expected);
  std::reverse(facets.begin(), facets.end());
  for (Facet& f : facets)
    std::reverse(f.v.begin(), f.v.end());
  EXPECT_EQ(overlapRadii(pts, facets, radius), expected);
}

TEST(CoconeEdgeUseMap, AgreesWithAStandardMapThroughInsertsAndErasures)
{
  // The clean-up's flat edge map against std::unordered_map: 20,000 random operations (add, look
  // up, erase, erase what is not there) on keys drawn from a few hundred edges, so that probe runs
  // collide, wrap round the table and are closed up by erasures; the table grows from empty. After
  // each batch, forEach visits exactly the entries the oracle holds.
  using pcl_ecs::surface::detail::EdgeUse;
  using pcl_ecs::surface::detail::EdgeUseMap;
  using pcl_ecs::surface::detail::edgeKey;
  std::mt19937 rng(7);
  std::uniform_int_distribution<std::uint32_t> vertex(0, 40);
  EdgeUseMap map;
  std::unordered_map<std::uint64_t, EdgeUse> oracle;
  for (int step = 0; step < 20000; ++step)
  {
    const std::uint32_t a = vertex(rng), b = vertex(rng);
    if (a == b)
      continue;
    const std::uint64_t key = edgeKey(a, b);
    switch (rng() % 4)
    {
      case 0:
      case 1:
      {
        EdgeUse& u = map[key];
        EdgeUse& o = oracle[key];
        ++u.count;
        ++o.count;
        u.from = o.from = a;
        break;
      }
      case 2:
        map.erase(key);
        oracle.erase(key);
        break;
      default:
      {
        const EdgeUse* u = map.find(key);
        const auto it = oracle.find(key);
        ASSERT_EQ(u != nullptr, it != oracle.end()) << "step " << step;
        EXPECT_EQ(map.contains(key), it != oracle.end());
        if (u)
        {
          EXPECT_EQ(u->count, it->second.count);
          EXPECT_EQ(u->from, it->second.from);
        }
      }
    }
    if (step % 1000 == 999)
    {
      std::map<std::uint64_t, std::pair<int, std::uint32_t>> seen, expected;
      map.forEach([&](std::uint64_t k, const EdgeUse& u) { EXPECT_TRUE(seen.emplace(k, std::make_pair(u.count, u.from)).second); });
      for (const auto& [k, o] : oracle)
        expected.emplace(k, std::make_pair(o.count, o.from));
      ASSERT_EQ(seen, expected) << "step " << step;
    }
  }
  EdgeUseMap empty;
  EXPECT_EQ(empty.find(edgeKey(1, 2)), nullptr);
  empty.erase(edgeKey(1, 2));  // nothing to erase, no table yet
  int visits = 0;
  empty.forEach([&](std::uint64_t, const EdgeUse&) { ++visits; });
  EXPECT_EQ(visits, 0);
}

TEST(CoconeSortTriangles, LexicographicOrderOnPackedKeysAndPastThem)
{
  // sortTriangles against std::sort: corners packed into one 64-bit key (21 bits each when the
  // points number 2^21) and, past that, a comparison sort; duplicates included.
  using pcl_ecs::surface::detail::sortTriangles;
  std::mt19937 rng(11);
  for (const std::size_t points : {std::size_t{5}, std::size_t{1000}, std::size_t{1} << 21, (std::size_t{1} << 21) + 1})
  {
    std::uniform_int_distribution<std::uint32_t> corner(0, static_cast<std::uint32_t>(points - 1));
    std::vector<Triangle> tris(3000);
    for (Triangle& t : tris)
      t = {corner(rng), corner(rng), corner(rng)};
    tris.push_back(tris[17]);
    tris.push_back({static_cast<std::uint32_t>(points - 1), 0, static_cast<std::uint32_t>(points - 1)});
    std::vector<Triangle> expected = tris;
    std::sort(expected.begin(), expected.end());
    sortTriangles(tris, points);
    EXPECT_EQ(tris, expected) << points << " points";
  }
}

namespace
{
/// keepManifold's rule written plainly, as the oracle: every edge in triangle order keeps its first
/// triangle and the first after it that runs the other way; then, until nothing changes, every
/// vertex keeps the largest of its fans (the first of the largest in triangle order), the fans found
/// by joining, pair by pair, the kept triangles at it that share a second corner.
std::vector<char> keepManifoldOracle(const std::vector<Triangle>& tris)
{
  std::vector<char> keep(tris.size(), 1);
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> at_edge;
  for (std::uint32_t t = 0; t < tris.size(); ++t)
    for (int k = 0; k < 3; ++k)
    {
      const std::uint32_t a = tris[t][k], b = tris[t][(k + 1) % 3];
      at_edge[{std::min(a, b), std::max(a, b)}].push_back(t);
    }
  auto runs = [&](std::uint32_t t, std::uint32_t a, std::uint32_t b) {
    for (int k = 0; k < 3; ++k)
      if (tris[t][k] == a && tris[t][(k + 1) % 3] == b)
        return true;
    return false;
  };
  for (const auto& [edge, ts] : at_edge)
  {
    const bool forward = runs(ts[0], edge.first, edge.second);
    bool paired = false;
    for (std::size_t i = 1; i < ts.size(); ++i)
      if (!paired && runs(ts[i], edge.first, edge.second) != forward)
        paired = true;
      else
        keep[ts[i]] = 0;
  }
  std::uint32_t n = 0;
  for (const Triangle& t : tris)
    n = std::max({n, t[0] + 1, t[1] + 1, t[2] + 1});
  for (bool changed = true; changed;)
  {
    changed = false;
    for (std::uint32_t v = 0; v < n; ++v)
    {
      std::vector<std::uint32_t> local;
      for (std::uint32_t t = 0; t < tris.size(); ++t)
        if (keep[t] && (tris[t][0] == v || tris[t][1] == v || tris[t][2] == v))
          local.push_back(t);
      std::vector<std::size_t> fan(local.size());
      std::iota(fan.begin(), fan.end(), 0);
      for (bool merged = true; merged;)
      {
        merged = false;
        for (std::size_t i = 0; i < local.size(); ++i)
          for (std::size_t j = 0; j < local.size(); ++j)
          {
            bool shared = false;
            for (const std::uint32_t x : tris[local[i]])
              if (x != v && (x == tris[local[j]][0] || x == tris[local[j]][1] || x == tris[local[j]][2]))
                shared = true;
            if (shared && fan[i] != fan[j])
            {
              const std::size_t lo = std::min(fan[i], fan[j]), hi = std::max(fan[i], fan[j]);
              for (std::size_t& f : fan)
                if (f == hi)
                  f = lo;
              merged = true;
            }
          }
      }
      std::vector<std::size_t> size(local.size(), 0);
      for (const std::size_t f : fan)
        ++size[f];
      std::size_t best = 0;
      for (std::size_t i = 1; i < local.size(); ++i)
        if (size[i] > size[best])
          best = i;
      for (std::size_t i = 0; i < local.size(); ++i)
        if (fan[i] != best)
        {
          keep[local[i]] = 0;
          changed = true;
        }
    }
  }
  return keep;
}
}  // namespace

TEST(CoconeKeepManifold, AgreesWithThePlainRuleOnTriangleSoups)
{
  // keepManifold against the oracle above on 300 random soups of 10-60 triangles over 6-14
  // vertices: edges held by three or more triangles, pairs that run the same way, vertices pinched
  // between fans, and fans that split once a neighbour's fan goes (a vertex looked at again).
  using pcl_ecs::surface::detail::keepManifold;
  std::mt19937 rng(5);
  int pinched = 0;
  for (int soup = 0; soup < 300; ++soup)
  {
    const std::uint32_t n = 6 + rng() % 9;
    std::uniform_int_distribution<std::uint32_t> corner(0, n - 1);
    std::vector<Triangle> tris;
    const std::size_t count = 10 + rng() % 51;
    while (tris.size() < count)
    {
      const Triangle t{corner(rng), corner(rng), corner(rng)};
      if (t[0] != t[1] && t[1] != t[2] && t[0] != t[2])
        tris.push_back(t);
    }
    const std::vector<char> expected = keepManifoldOracle(tris);
    ASSERT_EQ(keepManifold(tris, n), expected) << "soup " << soup;
    // The result is a manifold: no edge with more than two kept triangles.
    std::map<std::pair<std::uint32_t, std::uint32_t>, int> held;
    for (std::size_t t = 0; t < tris.size(); ++t)
      if (expected[t])
        for (int k = 0; k < 3; ++k)
          ++held[{std::min(tris[t][k], tris[t][(k + 1) % 3]), std::max(tris[t][k], tris[t][(k + 1) % 3])}];
    for (const auto& [edge, c] : held)
      EXPECT_LE(c, 2);
    pinched += std::count(expected.begin(), expected.end(), 0) > 0 ? 1 : 0;
  }
  EXPECT_GT(pinched, 250);  // most soups lose triangles: the cases above are met

  // A vertex looked at again: 0's fan T1-T2-T3-T4 is whole when 0 is first looked at; at 1, T2 and
  // T3 (joined through 0) are the smaller fan beside D-E-F and go, which splits 0's fan into T1
  // and T4, so 0 is looked at again and keeps T1 (the first of the two).
  const std::vector<Triangle> split = {{0, 4, 2}, {0, 2, 1}, {0, 1, 3}, {0, 3, 5}, {1, 6, 7}, {1, 7, 8}, {1, 8, 9}};
  const std::vector<char> kept = {1, 0, 0, 0, 1, 1, 1};
  EXPECT_EQ(keepManifoldOracle(split), kept);
  EXPECT_EQ(keepManifold(split, 10), kept);
}

TEST(CoconeSideNeighbours, EachSideHasTheOtherTriangleOfItsEdgeWhenExactlyTwoAreKept)
{
  // sideNeighbours against a brute force over every pair of kept triangles: a closed tetrahedron
  // (every side has its neighbour), an open fan beside it (boundary sides have none), an edge held
  // by three triangles (none on that edge), and a triangle left out (it has none, and counts for
  // no edge: the edge it would make a third of keeps its pair).
  using pcl_ecs::surface::detail::kNone;
  using pcl_ecs::surface::detail::sideNeighbours;
  using pcl_ecs::surface::detail::vertexStars;
  const std::vector<Triangle> tris = {
      {0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3},  // tetrahedron 0-3
      {4, 5, 6}, {4, 6, 7}, {4, 7, 8},             // open fan round 4
      {9, 10, 11}, {10, 9, 12}, {9, 10, 13},       // edge 9-10 held three times
      {0, 1, 14},                                  // left out: would be a third on edge 0-1
  };
  std::vector<char> keep(tris.size(), 1);
  keep.back() = 0;
  const std::size_t n = 15;
  const std::vector<std::uint32_t> nbr = sideNeighbours(tris, vertexStars(n, tris, &keep));
  ASSERT_EQ(nbr.size(), 3 * tris.size());
  auto hasEdge = [](const Triangle& t, std::uint32_t a, std::uint32_t b) {
    return std::count(t.begin(), t.end(), a) == 1 && std::count(t.begin(), t.end(), b) == 1;
  };
  for (std::uint32_t t = 0; t < tris.size(); ++t)
    for (std::uint32_t k = 0; k < 3; ++k)
    {
      std::vector<std::uint32_t> holders;
      for (std::uint32_t u = 0; u < tris.size(); ++u)
        if (keep[u] && hasEdge(tris[u], tris[t][k], tris[t][(k + 1) % 3]))
          holders.push_back(u);
      std::uint32_t expected = kNone;
      if (keep[t] && holders.size() == 2)
        expected = holders[0] == t ? holders[1] : holders[0];
      EXPECT_EQ(nbr[3 * t + k], expected) << "triangle " << t << " side " << k;
    }
  // The cases the brute force covers, spelled out.
  EXPECT_EQ(nbr[3 * 0 + 0], 3u);    // side 0-2 of {0, 2, 1}: {2, 0, 3}
  EXPECT_EQ(nbr[3 * 0 + 2], 1u);    // side 1-0: {0, 1, 3}, the left-out {0, 1, 14} not counted
  EXPECT_EQ(nbr[3 * 4 + 0], kNone);  // side 4-5 of the fan: a boundary
  EXPECT_EQ(nbr[3 * 4 + 2], 5u);    // side 6-4: {4, 6, 7}
  EXPECT_EQ(nbr[3 * 7 + 0], kNone);  // side 9-10: three triangles
  EXPECT_EQ(nbr[3 * 10 + 0], kNone);  // the left-out triangle
}

TEST(CoconeCleanUp, ASlitIsALoopNarrowerThanHalfItsSpacing)
{
  // A four-vertex loop 10 long and 2w wide (a rhombus: area 10 w, width w): a slit when w is below
  // half the smallest spacing at its vertices, in any orientation and whichever vertex starts it.
  using pcl_ecs::surface::detail::isSlit;
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  for (const double w : {0.1, 0.45, 0.55, 3.0})
  {
    std::vector<Eigen::Vector3d> points = {{0, 0, 0}, {5, w, 0}, {10, 0, 0}, {5, -w, 0}};
    for (Eigen::Vector3d& p : points)
      p = turn * p + Eigen::Vector3d(4, -2, 7);
    std::vector<double> spacing = {1.0, 1.5, 2.0, 1.2};
    SCOPED_TRACE(w);
    EXPECT_EQ(isSlit(points, spacing, {0, 1, 2, 3}), w < 0.5);
    EXPECT_EQ(isSlit(points, spacing, {2, 1, 0, 3}), w < 0.5);
    spacing[2] = 0.1;  // the smallest spacing decides
    EXPECT_EQ(isSlit(points, spacing, {1, 2, 3, 0}), w < 0.05);
  }
  // A unit square (width 1/√2) is no slit at spacing 1; at spacing 3 it is narrower than half of it.
  const std::vector<Eigen::Vector3d> square = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  EXPECT_FALSE(isSlit(square, std::vector<double>(4, 1.0), {0, 1, 2, 3}));
  EXPECT_TRUE(isSlit(square, std::vector<double>(4, 3.0), {0, 1, 2, 3}));
}

TEST(CoconeLargeComponents, ASmallClosedPieceLyingOnTheSurfaceIsASecondLayer)
{
  // keepLargeComponents on a flat grid of 2,400 triangles (the largest piece, open) and four small
  // pieces: a closed icosahedron of radius 0.2 lying on the grid (every vertex within 0.3 of it,
  // under half the spacing 1: a second layer, dropped), the same one 3 above the grid (kept), the
  // same one on the grid with a triangle missing (open: kept) and a closed tetrahedron far off (4
  // triangles, under min_component_triangles: dropped).
  using pcl_ecs::surface::detail::keepLargeComponents;
  std::vector<Eigen::Vector3d> points;
  std::vector<Triangle> tris;
  const int nx = 41, ny = 31;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      points.emplace_back(i, j, 0.0);
  for (int j = 0; j + 1 < ny; ++j)
    for (int i = 0; i + 1 < nx; ++i)
    {
      const auto v = static_cast<std::uint32_t>(j * nx + i);
      tris.push_back({v, v + 1, v + nx + 1});
      tris.push_back({v, v + nx + 1, v + nx});
    }
  const std::size_t grid_triangles = tris.size();
  ASSERT_EQ(grid_triangles, 2400u);
  // The icosahedron's faces: the triples of its 12 vertices at distance 2 pairwise, facing out.
  const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> ico;
  for (const double a : {-1.0, 1.0})
    for (const double b : {-phi, phi})
    {
      ico.emplace_back(0, a, b);
      ico.emplace_back(a, b, 0);
      ico.emplace_back(b, 0, a);
    }
  std::vector<Triangle> ico_faces;
  for (std::uint32_t a = 0; a < 12; ++a)
    for (std::uint32_t b = a + 1; b < 12; ++b)
      for (std::uint32_t c = b + 1; c < 12; ++c)
      {
        auto edge = [&](std::uint32_t x, std::uint32_t y) { return std::abs((ico[x] - ico[y]).norm() - 2.0) < 1e-9; };
        if (!edge(a, b) || !edge(b, c) || !edge(a, c))
          continue;
        const Eigen::Vector3d n = (ico[b] - ico[a]).cross(ico[c] - ico[a]);
        ico_faces.push_back(n.dot(ico[a] + ico[b] + ico[c]) > 0 ? Triangle{a, b, c} : Triangle{a, c, b});
      }
  ASSERT_EQ(ico_faces.size(), 20u);
  auto addIcosahedron = [&](const Eigen::Vector3d& centre, std::size_t faces) {
    const auto first = static_cast<std::uint32_t>(points.size());
    const double scale = 0.2 / std::sqrt(1.0 + phi * phi);  // circumradius 0.2
    for (const Eigen::Vector3d& v : ico)
      points.push_back(centre + scale * v);
    for (std::size_t f = 0; f < faces; ++f)
      tris.push_back({first + ico_faces[f][0], first + ico_faces[f][1], first + ico_faces[f][2]});
  };
  addIcosahedron({10, 10, 0.1}, 20);  // on the grid: a second layer
  addIcosahedron({20, 10, 3.0}, 20);  // above it: a piece of its own
  addIcosahedron({30, 10, 0.1}, 19);  // on the grid but open
  {
    const auto f = static_cast<std::uint32_t>(points.size());
    for (const Eigen::Vector3d& v : {Eigen::Vector3d(100, 0, 0), Eigen::Vector3d(101, 0, 0), Eigen::Vector3d(100, 1, 0),
                                     Eigen::Vector3d(100, 0, 1)})
      points.push_back(v);
    for (const Triangle& t : {Triangle{0, 2, 1}, Triangle{0, 1, 3}, Triangle{1, 2, 3}, Triangle{2, 0, 3}})
      tris.push_back({f + t[0], f + t[1], f + t[2]});
  }
  const std::vector<double> spacing(points.size(), 1.0);
  const std::vector<char> keep(tris.size(), 1);
  const std::vector<std::uint32_t> nbr = pcl_ecs::surface::detail::sideNeighbours(
      tris, pcl_ecs::surface::detail::vertexStars(points.size(), tris, &keep));
  pcl_ecs::surface::CoconeStats st;
  const std::vector<Triangle> kept = keepLargeComponents(points, spacing, tris, keep, nbr, CoconeParameters(), st);
  EXPECT_EQ(st.dropped_layers, 1u);
  EXPECT_EQ(st.components, 3u);
  ASSERT_EQ(kept.size(), grid_triangles + 20 + 19);
  // The grid and the two kept pieces, in their order; nothing of the dropped ones.
  EXPECT_TRUE(std::equal(tris.begin(), tris.begin() + static_cast<std::ptrdiff_t>(grid_triangles), kept.begin()));
  const auto first_kept_ico = static_cast<std::ptrdiff_t>(grid_triangles + 20);
  EXPECT_TRUE(std::equal(tris.begin() + first_kept_ico, tris.begin() + first_kept_ico + 39,
                         kept.begin() + static_cast<std::ptrdiff_t>(grid_triangles)));
  // With the spacing halved the bound is 0.25, and the icosahedron's highest vertices lie 0.27 above
  // the grid (0.1 + 0.2 × 0.85): not every vertex is within it, so it stays.
  pcl_ecs::surface::CoconeStats st2;
  const std::vector<double> tight(points.size(), 0.5);
  keepLargeComponents(points, tight, tris, keep, nbr, CoconeParameters(), st2);
  EXPECT_EQ(st2.dropped_layers, 0u);
}

namespace
{
/// A UV sphere of radius 1 about the origin: `rings` rings of `segments` points between the poles
/// (point 0 the north pole, the last the south pole), triangles facing out, listed ring band by
/// ring band from the north (band b joins ring b − 1 and ring b; band 0 is the north fan).
struct UvSphere
{
  std::vector<Eigen::Vector3d> points;
  std::vector<std::vector<Triangle>> bands;
};

UvSphere uvSphere(int rings, int segments)
{
  UvSphere s;
  const double pi = 3.14159265358979323846;
  s.points.emplace_back(0, 0, 1);
  for (int r = 1; r <= rings; ++r)
  {
    const double theta = pi * r / (rings + 1);
    for (int k = 0; k < segments; ++k)
    {
      const double phi = 2 * pi * k / segments;
      s.points.emplace_back(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
    }
  }
  s.points.emplace_back(0, 0, -1);
  auto at = [&](int r, int k) { return static_cast<std::uint32_t>(1 + (r - 1) * segments + (k % segments)); };
  const auto south = static_cast<std::uint32_t>(s.points.size() - 1);
  s.bands.resize(rings + 1);
  for (int k = 0; k < segments; ++k)
    s.bands[0].push_back({0, at(1, k), at(1, k + 1)});
  for (int r = 2; r <= rings; ++r)
    for (int k = 0; k < segments; ++k)
    {
      s.bands[r - 1].push_back({at(r - 1, k), at(r, k), at(r, k + 1)});
      s.bands[r - 1].push_back({at(r - 1, k), at(r, k + 1), at(r - 1, k + 1)});
    }
  for (int k = 0; k < segments; ++k)
    s.bands[rings].push_back({south, at(rings, k + 1), at(rings, k)});
  return s;
}

/// Runs the clean-up step on `walked` triangles (also the candidates), with the given spacing.
std::vector<Triangle> cleanUpOnly(const std::vector<Eigen::Vector3d>& points, double spacing,
                                  std::vector<Triangle> walked, pcl_ecs::surface::CoconeStats& st)
{
  namespace d = pcl_ecs::surface::detail;
  const std::vector<Triangle> cand = walked;
  const std::vector<char> alive(cand.size(), 1);
  const d::EdgeIndex edges(cand);
  d::Extraction ex;
  ex.out = std::move(walked);
  ex.order.resize(ex.out.size());
  std::iota(ex.order.begin(), ex.order.end(), 0u);
  const std::vector<double> sp(points.size(), spacing);
  return d::cleanUp(points, sp, CoconeParameters(), cand, alive, edges, ex, {}, st);
}

/// The mesh is one closed 2-manifold of a sphere's topology (χ 2) over the sphere's points.
void expectOneClosedSphere(const std::vector<Eigen::Vector3d>& points, const std::vector<Triangle>& mesh)
{
  const MeshTopology t = analyzeTopology(points.size(), mesh);
  EXPECT_TRUE(t.isClosedManifold());
  EXPECT_EQ(t.euler_characteristic, 2);
  EXPECT_EQ(t.components, 1u);
}

/// Every triangle faces away from the origin (the sphere's outside).
bool facesOut(const std::vector<Eigen::Vector3d>& p, const std::vector<Triangle>& tris)
{
  for (const Triangle& t : tris)
  {
    const Eigen::Vector3d n = (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
    if (n.dot(p[t[0]] + p[t[1]] + p[t[2]]) <= 0)
      return false;
  }
  return true;
}

/// How the edges of `mesh` (a closed 2-manifold) between two triangles `select` picks bend it.
struct Bending
{
  std::size_t edges = 0;       ///< the edges selected
  std::size_t improvable = 0;  ///< of those, the ones a flip would make bend the surface less
  double total = 0;            ///< the sum over them of 1 − cos of the angle between the normals
};
/// An edge is improvable when flipping it to the other diagonal of its quad (not in the mesh
/// already) lowers the sum of (1 − cos) of the angles between the normals across the five edges a
/// flip changes (the diagonal and the quad's four sides), as the clean-up's flips measure it.
template <typename Select>
Bending bending(const std::vector<Eigen::Vector3d>& p, const std::vector<Triangle>& mesh, Select select)
{
  auto unit = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    return (p[b] - p[a]).cross(p[c] - p[a]).normalized().eval();
  };
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::size_t>> at;  // edge → triangles
  for (std::size_t i = 0; i < mesh.size(); ++i)
    for (int k = 0; k < 3; ++k)
      at[{std::min(mesh[i][k], mesh[i][(k + 1) % 3]), std::max(mesh[i][k], mesh[i][(k + 1) % 3])}].push_back(i);
  auto other = [&](std::uint32_t a, std::uint32_t b, std::size_t tri) -> const Triangle* {
    for (std::size_t x : at.at({std::min(a, b), std::max(a, b)}))
      if (x != tri)
        return &mesh[x];
    return nullptr;
  };
  auto bend = [&](const Eigen::Vector3d& n, const Triangle* o) {
    return o ? 1 - n.dot(unit((*o)[0], (*o)[1], (*o)[2])) : 0.0;
  };
  Bending result;
  for (std::size_t i = 0; i < mesh.size(); ++i)
    for (int k = 0; k < 3; ++k)
    {
      const std::uint32_t a = mesh[i][k], b = mesh[i][(k + 1) % 3];
      const auto& v = at.at({std::min(a, b), std::max(a, b)});
      const std::size_t j = v[0] == i ? v[1] : v[0];
      if (j < i || !select(mesh[i], mesh[j]))
        continue;
      ++result.edges;
      const std::uint32_t c = mesh[i][(k + 2) % 3];
      std::uint32_t d = mesh[j][0];
      for (std::uint32_t x : mesh[j])
        if (x != a && x != b)
          d = x;
      const Eigen::Vector3d n1 = unit(a, b, c), n2 = unit(b, a, d), m1 = unit(c, a, d), m2 = unit(d, b, c);
      result.total += 1 - n1.dot(n2);
      if (at.count({std::min(c, d), std::max(c, d)}))
        continue;  // the other diagonal is in the mesh already
      const Triangle *nbc = other(b, c, i), *nca = other(c, a, i), *nad = other(a, d, j), *ndb = other(d, b, j);
      const double now = bend(n1, nbc) + bend(n1, nca) + bend(n2, nad) + bend(n2, ndb) + (1 - n1.dot(n2));
      const double flipped = bend(m2, nbc) + bend(m1, nca) + bend(m1, nad) + bend(m2, ndb) + (1 - m1.dot(m2));
      result.improvable += flipped < now - 1e-9 ? 1 : 0;
    }
  return result;
}
}  // namespace

TEST(CoconeCleanUp, APieceInsideOutIsTurnedAndJoinedBack)
{
  // A sphere whose walk lost the band of triangles between its 2nd and 3rd rings and came back onto
  // the northern cap upside down: the cap takes the body's orientation and the two loops that face
  // each other across the band are joined by a band of 2 × 48 triangles: the closed sphere again.
  const UvSphere s = uvSphere(20, 48);
  std::vector<Triangle> walked;
  for (std::size_t b = 4; b < s.bands.size(); ++b)  // the body first (the walk starts at the hull)
    walked.insert(walked.end(), s.bands[b].begin(), s.bands[b].end());
  for (std::size_t b = 0; b < 3; ++b)  // the cap, reversed
    for (Triangle t : s.bands[b])
    {
      std::swap(t[1], t[2]);
      walked.push_back(t);
    }
  pcl_ecs::surface::CoconeStats st;
  const double spacing = 2 * 3.14159265358979323846 / 48;  // the ring's edge at the equator
  const std::vector<Triangle> mesh = cleanUpOnly(s.points, spacing, walked, st);
  expectOneClosedSphere(s.points, mesh);
  EXPECT_EQ(analyzeTopology(s.points.size(), mesh).used_vertices, s.points.size());
  EXPECT_TRUE(facesOut(s.points, mesh));
  EXPECT_EQ(st.reoriented_pieces, 1u);
  EXPECT_EQ(st.stitched_loops, 1u);
  EXPECT_EQ(st.stitched_triangles, 2u * 48u);
  EXPECT_EQ(st.filled_triangles, 0u);
}

TEST(CoconeCleanUp, TwoLoopsOfOnePieceAreClosedNotJoined)
{
  // The belt of a sphere between its 5th and 8th rings of 12: one piece with two loops that face
  // each other (their vector areas point opposite ways, their centres 0.71 apart, closer than the
  // sum of their radii, 1.87). With
  // a spacing so large that the gap guard allows a band between them, joining them would make a
  // handle (a tube through the sphere, χ 0); each is closed on its own instead (χ 2).
  const UvSphere s = uvSphere(12, 24);
  std::vector<Triangle> walked;
  for (std::size_t b = 6; b <= 8; ++b)
    walked.insert(walked.end(), s.bands[b].begin(), s.bands[b].end());
  pcl_ecs::surface::CoconeStats st;
  const std::vector<Triangle> mesh = cleanUpOnly(s.points, 1.0, walked, st);
  expectOneClosedSphere(s.points, mesh);
  EXPECT_TRUE(facesOut(s.points, mesh));
  EXPECT_EQ(st.stitched_loops, 0u);
  EXPECT_EQ(st.reoriented_pieces, 0u);
  EXPECT_GT(st.filled_triangles, 0u);
}

TEST(CoconeCleanUp, EarClippedTrianglesAreFlippedToFollowTheSurface)
{
  // A hole of 4 bands × 6 segments cut out of a UV sphere: its loop is not planar, and the ear
  // clipping (shortest chord first) leaves diagonals that bend the fill more than the other
  // diagonal of their quad would. After the flips no edge between two fill triangles can be
  // flipped to bend the surface less (checked here independently, on the five angles a flip
  // changes; without the flips this fails on several edges). The flips do not undo a fold the clipping
  // made (a reflex ear over its neighbours): a fill triangle here faces in either way.
  const UvSphere s = uvSphere(16, 32);
  std::vector<Triangle> walked;
  std::set<std::array<std::uint32_t, 3>> removed;
  for (std::size_t b = 0; b < s.bands.size(); ++b)
    for (std::size_t i = 0; i < s.bands[b].size(); ++i)
    {
      const bool hole = b >= 5 && b <= 8 && (i / 2) < 6;  // 6 segments of 4 bands
      if (hole)
        removed.insert(s.bands[b][i]);
      else
        walked.push_back(s.bands[b][i]);
    }
  auto key = [](Triangle t) {
    std::sort(t.begin(), t.end());
    return t;
  };
  std::set<Triangle> walked_set;
  for (const Triangle& t : walked)
    walked_set.insert(key(t));
  pcl_ecs::surface::CoconeStats st;
  const std::vector<Triangle> mesh = cleanUpOnly(s.points, 1.0, walked, st);
  expectOneClosedSphere(s.points, mesh);
  ASSERT_TRUE(analyzeTopology(s.points.size(), mesh).isClosedManifold());  // the edge map below needs it
  EXPECT_GT(st.filled_triangles, 0u);
  EXPECT_GT(st.flipped_edges, 0u);
  const auto& p = s.points;
  std::size_t fills = 0;
  double depth = 0;
  for (const Triangle& t : mesh)
    if (!walked_set.count(key(t)))
    {
      ++fills;
      depth += 1 - ((p[t[0]] + p[t[1]] + p[t[2]]) / 3).norm();
    }
  const Bending fill = bending(
      p, mesh, [&](const Triangle& t1, const Triangle& t2) { return !walked_set.count(key(t1)) && !walked_set.count(key(t2)); });
  EXPECT_EQ(fills, st.filled_triangles);
  EXPECT_GT(fill.edges, 0u);
  EXPECT_EQ(fill.improvable, 0u);
  // For the record: the fill spans the hole without its inner points, so it lies deeper than the
  // sphere's own triangles did.
  double ref_depth = 0;
  for (const Triangle& r : removed)
    ref_depth += 1 - ((p[r[0]] + p[r[1]] + p[r[2]]) / 3).norm();
  ref_depth /= static_cast<double>(removed.size());
  std::printf("fill: %zu triangles, %zu flips, mean centroid depth %.4g (the sphere's own triangles %.4g)\n", fills,
              st.flipped_edges, depth / static_cast<double>(fills), ref_depth);
}

TEST(CoconeCleanUp, EveryEdgeIsFlippedToBendTheSurfaceLess)
{
  // A bumpy UV sphere (radius 1 + 0.08 sin 5θ cos 7φ): its quads are not planar, and the UV
  // triangulation cuts each of them along the same diagonal, often the one that bends the surface
  // more. Nothing is filled, yet the clean-up flips edges: of the edges a flip would make bend the
  // surface less (measured independently on the five angles a flip changes), 400 of 1,536 before,
  // 32 are left (each flip queues the quad's four sides again, not the edges
  // around them, whose measure it also changes), the total bending falls, and the mesh stays one
  // closed sphere.
  UvSphere s = uvSphere(16, 32);
  for (Eigen::Vector3d& x : s.points)
  {
    const double theta = std::acos(std::max(-1.0, std::min(1.0, x.z()))), phi = std::atan2(x.y(), x.x());
    x *= 1 + 0.08 * std::sin(5 * theta) * std::cos(7 * phi);
  }
  std::vector<Triangle> walked;
  for (const auto& band : s.bands)
    walked.insert(walked.end(), band.begin(), band.end());
  const auto all = [](const Triangle&, const Triangle&) { return true; };
  pcl_ecs::surface::CoconeStats st;
  const std::vector<Triangle> mesh = cleanUpOnly(s.points, 1.0, walked, st);
  expectOneClosedSphere(s.points, mesh);
  EXPECT_EQ(st.filled_triangles, 0u);
  EXPECT_GT(st.flipped_edges, 50u);
  const Bending before = bending(s.points, walked, all), after = bending(s.points, mesh, all);
  EXPECT_EQ(before.edges, 3 * walked.size() / 2);
  EXPECT_EQ(after.edges, before.edges);
  EXPECT_GT(before.improvable, 300u);
  EXPECT_LT(after.improvable, before.improvable / 10);
  EXPECT_LT(after.total, before.total);
  std::printf("bumpy sphere: %zu flips; improvable edges %zu -> %zu of %zu; total bending %.4g -> %.4g\n",
              st.flipped_edges, before.improvable, after.improvable, after.edges, before.total, after.total);
}

namespace
{
/// A UV sphere with a small handle: two triangles of its 6th band, three segments apart, replaced
/// by a tube of six triangles between their loops (χ 0, one closed, oriented piece), the two
/// triangles' vertices returned in `ends`.
std::vector<Triangle> sphereWithSmallHandle(const UvSphere& s, std::vector<std::uint32_t>& ends)
{
  const Triangle a = s.bands[5][0], t2 = s.bands[5][6];
  const Triangle b = {t2[0], t2[2], t2[1]};  // the tube runs b backwards, as t2 ran it
  std::vector<Triangle> walked;
  for (const auto& band : s.bands)
    for (const Triangle& t : band)
      if (t != a && t != t2)
        walked.push_back(t);
  for (int i = 0; i < 3; ++i)
  {
    walked.push_back({a[i], a[(i + 1) % 3], b[i]});
    walked.push_back({b[i], a[(i + 1) % 3], b[(i + 1) % 3]});
  }
  ends = {a[0], a[1], a[2], t2[0], t2[1], t2[2]};
  return walked;
}
}  // namespace

TEST(CoconeCleanUp, ASmallHandleIsCutOut)
{
  // The three edges around either end of the tube make a cycle that is no triangle and does not
  // separate the mesh: the triangles at one end's vertices are removed, the hole they leave and
  // the other end's are closed, and the sphere comes back closed with χ 2, less the three vertices.
  const UvSphere s = uvSphere(12, 24);
  std::vector<std::uint32_t> ends;
  const std::vector<Triangle> walked = sphereWithSmallHandle(s, ends);
  const MeshTopology before = analyzeTopology(s.points.size(), walked);
  ASSERT_TRUE(before.isClosedManifold());
  ASSERT_EQ(before.euler_characteristic, 0);
  pcl_ecs::surface::CoconeStats st;
  const double spacing = 2 * 3.14159265358979323846 / 24;
  const std::vector<Triangle> mesh = cleanUpOnly(s.points, spacing, walked, st);
  expectOneClosedSphere(s.points, mesh);
  EXPECT_TRUE(facesOut(s.points, mesh));
  EXPECT_EQ(st.removed_handles, 1u);
  EXPECT_EQ(analyzeTopology(s.points.size(), mesh).used_vertices, s.points.size() - 3);
  std::size_t ends_used = 0;
  for (const std::uint32_t v : ends)
    ends_used += std::any_of(mesh.begin(), mesh.end(), [&](const Triangle& t) { return std::count(t.begin(), t.end(), v) > 0; });
  EXPECT_EQ(ends_used, 3u);  // one end's vertices are gone, the other's close its hole
}

TEST(CoconeCleanUp, AHandleWhoseHolesTheGuardKeepsOpenStays)
{
  // The same handle with a spacing so small that the gap guard refuses every chord: the holes the
  // cut would open cannot be closed, so nothing is cut and the mesh keeps its handle.
  const UvSphere s = uvSphere(12, 24);
  std::vector<std::uint32_t> ends;
  const std::vector<Triangle> walked = sphereWithSmallHandle(s, ends);
  pcl_ecs::surface::CoconeStats st;
  const std::vector<Triangle> mesh = cleanUpOnly(s.points, 1e-3, walked, st);
  const MeshTopology t = analyzeTopology(s.points.size(), mesh);
  EXPECT_TRUE(t.isClosedManifold());
  EXPECT_EQ(t.euler_characteristic, 0);
  EXPECT_EQ(t.used_vertices, s.points.size());
  EXPECT_EQ(st.removed_handles, 0u);
  EXPECT_EQ(mesh.size(), walked.size());
}

TEST(CoconeCleanUp, AThinPartSampledAroundItsGirthIsKept)
{
  // The same handle, the spacing set from the longest edge of the cycles around the tube's ends.
  // At 0.95 × that edge / kThinPartGirth it is a handle the walk made: cut (χ 2). At 2 × it the
  // tube's samples lie far closer to each other than the sampling around them: a thin part of
  // the object, kept (χ 0). (Between the two, the edge flips at one end of the tube make a cycle
  // around it whose longest edge is twice as long, and that one is cut.)
  using pcl_ecs::surface::detail::kThinPartGirth;
  const UvSphere s = uvSphere(12, 24);
  std::vector<std::uint32_t> ends;
  const std::vector<Triangle> walked = sphereWithSmallHandle(s, ends);
  double longest = 0.0;
  for (int e = 0; e < 2; ++e)
    for (int k = 0; k < 3; ++k)
      longest = std::max(longest, (s.points[ends[3 * e + k]] - s.points[ends[3 * e + (k + 1) % 3]]).norm());
  for (const double f : {2.0, 0.95})
  {
    SCOPED_TRACE(f);
    pcl_ecs::surface::CoconeStats st;
    const std::vector<Triangle> mesh = cleanUpOnly(s.points, f * longest / kThinPartGirth, walked, st);
    const MeshTopology t = analyzeTopology(s.points.size(), mesh);
    EXPECT_TRUE(t.isClosedManifold());
    EXPECT_EQ(t.components, 1u);
    EXPECT_EQ(t.euler_characteristic, f > 1.0 ? 0 : 2);
    EXPECT_EQ(st.removed_handles, f > 1.0 ? 0u : 1u);
  }
}

TEST(CoconeCleanUp, ARestNoWiderThanItsOwnEdgesIsClosed)
{
  // A closed box 0.5 high on a parallelogram, its base's two triangles taken out: a four-edge
  // hole with sides 1 long and ends 0.15 (no slit at spacing 0.1: its width, 0.11-0.15, is over
  // half the spacing). The gap guard (5 × 0.1) refuses both diagonals. Skewed by 0.3, the shorter
  // diagonal (0.72) is shorter than the hole's sides: the hole is closed, a box again (χ 2). As a
  // rectangle, both diagonals (1.01) are longer than every edge of the hole: it stays open.
  for (const double skew : {0.3, 0.0})
  {
    SCOPED_TRACE(skew);
    std::vector<Eigen::Vector3d> p = {{0, 0, 0}, {1, 0, 0}, {1 + skew, 0.15, 0}, {skew, 0.15, 0}};
    for (int k = 0; k < 4; ++k)
      p.push_back(p[static_cast<std::size_t>(k)] + Eigen::Vector3d(0, 0, 0.5));
    for (Eigen::Vector3d& x : p)
      x -= Eigen::Vector3d(0.5 + 0.5 * skew, 0.075, 0.25);  // centred: facesOut looks from the centre
    std::vector<Triangle> walked = {{4, 5, 6}, {4, 6, 7}};  // the top, facing up
    for (std::uint32_t k = 0; k < 4; ++k)
    {
      const std::uint32_t n = (k + 1) % 4;  // the side from k to n, facing out
      walked.push_back({k, n, n + 4});
      walked.push_back({k, n + 4, k + 4});
    }
    ASSERT_EQ(analyzeTopology(p.size(), walked).boundary_edges, 4u);
    pcl_ecs::surface::CoconeStats st;
    const std::vector<Triangle> mesh = cleanUpOnly(p, 0.1, walked, st);
    const MeshTopology t = analyzeTopology(p.size(), mesh);
    EXPECT_TRUE(t.isManifold());
    if (skew > 0.0)
    {
      EXPECT_TRUE(t.isClosedManifold());
      EXPECT_EQ(t.euler_characteristic, 2);
      EXPECT_EQ(st.filled_triangles, 2u);
      EXPECT_TRUE(facesOut(p, mesh));
    }
    else
    {
      EXPECT_EQ(t.boundary_edges, 4u);
      EXPECT_EQ(st.filled_triangles, 0u);
      EXPECT_EQ(st.narrowed_loops, 1u);
    }
  }
}

TEST(CoconeCleanUp, AHoleClosedButForAGapWiderThanTheGuardKeepsItsTriangles)
{
  // A sphere without its northern cap: one planar hole, a regular 24-gon of circumradius ρ (ring 3
  // of 12). Shortest chord first, the ear clipping takes every other vertex (chords 0.52 ρ), then
  // every other one of the 12-gon left (chords ρ), then needs the 6-gon's chords, √3 ρ. With the
  // gap guard (5 × the spacing) at 1.3 ρ it stops at that 6-gon: the 18 triangles made stay, and
  // so does the 6-edge gap. At 0.8 ρ it stops at the 12-gon, more than 8 vertices: nothing is
  // added. At 2 ρ the hole is closed (22 triangles, a closed sphere).
  const UvSphere s = uvSphere(12, 24);
  const double rho = std::sin(3.14159265358979323846 * 3 / 13);
  std::vector<Triangle> walked;
  for (std::size_t b = 3; b < s.bands.size(); ++b)
    walked.insert(walked.end(), s.bands[b].begin(), s.bands[b].end());
  struct Case
  {
    double guard_over_rho;
    std::size_t filled, narrowed, boundary_edges;
  };
  for (const Case& c : {Case{1.3, 18, 1, 6}, Case{0.8, 0, 0, 24}, Case{2.0, 22, 0, 0}})
  {
    SCOPED_TRACE(c.guard_over_rho);
    pcl_ecs::surface::CoconeStats st;
    const double spacing = c.guard_over_rho * rho / CoconeParameters().max_edge_ratio;
    const std::vector<Triangle> mesh = cleanUpOnly(s.points, spacing, walked, st);
    const MeshTopology t = analyzeTopology(s.points.size(), mesh);
    EXPECT_TRUE(t.isManifold());
    EXPECT_TRUE(t.consistently_oriented);
    EXPECT_EQ(t.components, 1u);
    EXPECT_EQ(st.filled_triangles, c.filled);
    EXPECT_EQ(st.narrowed_loops, c.narrowed);
    EXPECT_EQ(t.boundary_edges, c.boundary_edges);
    EXPECT_EQ(t.boundary_loops, c.boundary_edges > 0 ? 1u : 0u);
    EXPECT_TRUE(facesOut(s.points, mesh));
    // Every added triangle keeps within the guard.
    for (std::size_t i = walked.size(); i < mesh.size(); ++i)
      for (int k = 0; k < 3; ++k)
        EXPECT_LE((s.points[mesh[i][k]] - s.points[mesh[i][(k + 1) % 3]]).norm(), c.guard_over_rho * rho * (1 + 1e-9));
  }
}

// ---- a real scan ---------------------------------------------------------------------------------

#include <pcl_ecs/eval/quality_metrics.h>
#include <pcl_ecs/feature_aware_cover_simplify.h>

#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

namespace
{
/// A PLY mesh as the metrics take it; false when it cannot be read.
bool loadTriangleMesh(const std::string& path, pcl_ecs::eval::TriangleMesh& out)
{
  pcl::PolygonMesh pm;
  if (pcl::io::loadPLYFile(path, pm) != 0)
    return false;
  pcl::PointCloud<pcl::PointXYZ> v;
  pcl_ecs::io::fromCloud(pm.cloud, v);
  out = {};
  for (const auto& p : v)
    out.vertices.emplace_back(p.x, p.y, p.z);
  for (const auto& poly : pm.polygons)
    out.triangles.emplace_back(poly.vertices[0], poly.vertices[1], poly.vertices[2]);
  return true;
}

/// The metrics' mesh of `triangles` over `points`.
pcl_ecs::eval::TriangleMesh asTriangleMesh(const std::vector<Eigen::Vector3d>& points, const std::vector<Triangle>& triangles)
{
  pcl_ecs::eval::TriangleMesh m;
  m.vertices = points;
  for (const Triangle& tri : triangles)
    m.triangles.emplace_back(tri[0], tri[1], tri[2]);
  return m;
}
}  // namespace

TEST(CoconeScan, BunnyIsAManifoldCloseToTheReference)
{
  const std::string cloud_path = pcl_ecs_test::sharedData("bunny.pcd");
  const std::string mesh_path = pcl_ecs_test::sharedData("bunny_mesh.ply");
  pcl::PointCloud<pcl::PointXYZ> cloud;
  pcl_ecs::eval::TriangleMesh ref;
  if (pcl::io::loadPCDFile(cloud_path, cloud) != 0 || !loadTriangleMesh(mesh_path, ref))
    GTEST_SKIP() << "shared data missing";
  std::vector<Eigen::Vector3d> pts;
  for (const auto& p : cloud)
    pts.emplace_back(p.x, p.y, p.z);
  const auto r = coconeReconstruct(pts);
  ASSERT_TRUE(r.ok()) << r.error;
  const MeshTopology t = analyzeTopology(pts.size(), r.triangles);
  EXPECT_TRUE(t.isManifold());
  EXPECT_TRUE(t.consistently_oriented);
  EXPECT_EQ(t.nonmanifold_edges, 0u);
  // One surface: the hole filling closes the open base.
  EXPECT_EQ(t.components, 1u);
  // The merged scans leave the bunny's base open: a handful of loops, bounded.
  RecordProperty("boundary_loops", static_cast<int>(t.boundary_loops));
  std::printf("bunny: %zu triangles, %zu boundary loops, %zu used of %zu points\n", t.triangles, t.boundary_loops,
              t.used_vertices, pts.size());
  EXPECT_LE(t.boundary_loops, 15u);
  // Unused: the duplicates (and any sample no kept triangle reaches).
  EXPECT_GE(static_cast<double>(t.used_vertices), 0.998 * static_cast<double>(pts.size()));

  pcl_ecs::eval::MeshDistance d;
  ASSERT_TRUE(pcl_ecs::eval::meshDistance(asTriangleMesh(pts, r.triangles), ref, d));
  std::printf("bunny: mesh to reference mean %.3g L max %.3g L; reference to mesh mean %.3g L max %.3g L\n",
              d.to_reference_mean, d.to_reference_max, d.from_reference_mean, d.from_reference_max);
  // Stated bounds (relative to L): the surface lies on the reference (mean 1e-4); the largest
  // deviations are the triangles that close the reference's own holes at the base.
  EXPECT_LT(d.to_reference_mean, 1e-4);
  EXPECT_LT(d.from_reference_mean, 1e-4);
  EXPECT_LT(d.to_reference_max, 0.04);
  EXPECT_LT(d.from_reference_max, 0.01);
}

namespace
{
/// A shared scan (NAME_scan.pcd) simplified to `percent`% of its points (a target size): the output
/// points, their ball radii (pointRadii), the reference mesh (NAME_mesh.ply) and the scan with the
/// sample standing for each of its points (Result::input_to_output); `error` set when the filter
/// failed. False when the shared data is missing.
struct SimplifiedScan
{
  std::vector<Eigen::Vector3d> points;
  std::vector<double> radius;
  pcl_ecs::eval::TriangleMesh reference;
  pcl_ecs::surface::ScanSupport scan;
  std::string error;
};
bool simplifiedScan(const std::string& name, std::size_t percent, SimplifiedScan& s)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  if (pcl::io::loadPCDFile(pcl_ecs_test::sharedData(name + "_scan.pcd"), *cloud) != 0 ||
      !loadTriangleMesh(pcl_ecs_test::sharedData(name + "_mesh.ply"), s.reference))
    return false;
  pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ> f;
  f.setInputCloud(cloud);
  f.setTargetSize(cloud->size() * percent / 100);
  pcl::PointCloud<pcl::PointXYZ> out;
  f.filter(out);
  s.error = f.getResult().error;
  for (const auto& p : out)
    s.points.emplace_back(p.x, p.y, p.z);
  s.radius = pcl_ecs::pointRadii(f.getResult());
  if (s.error.empty() && s.radius.size() != s.points.size())
    s.error = "pointRadii gives " + std::to_string(s.radius.size()) + " radii for " + std::to_string(s.points.size()) + " points";
  s.scan = pcl_ecs::scanSupport(*cloud, f.getResult().input_to_output);
  return true;
}
bool simplifiedPinion(std::size_t percent, SimplifiedScan& s) { return simplifiedScan("pinion", percent, s); }
/// The distances between a mesh of the simplified pinion's points and the reference.
bool toReference(const SimplifiedScan& s, const std::vector<Triangle>& triangles, pcl_ecs::eval::MeshDistance& d)
{
  return pcl_ecs::eval::meshDistance(asTriangleMesh(s.points, triangles), s.reference, d);
}
}  // namespace

TEST(CoconeScan, TheSimplifiedGearHasNoTrianglesAcrossItsTeeth)
{
  // The pinion scan simplified to 10%: between its teeth the sparse representatives of the flanks
  // pass the cocone test across the gaps. Given each point's ball radius (pointRadii), Cocone refuses
  // the triangles joining balls that do not overlap: the mesh lies closer to the reference (its
  // mean distance 0.94 ×, its largest 0.58 × the ones without radii) and stays manifold.
  SimplifiedScan s;
  if (!simplifiedPinion(10, s))
    GTEST_SKIP() << "shared data missing";
  ASSERT_TRUE(s.error.empty()) << s.error;
  const auto& pts = s.points;
  const auto plain = coconeReconstruct(pts);
  const auto with = coconeReconstruct(pts, CoconeParameters(), s.radius);
  ASSERT_TRUE(plain.ok() && with.ok());
  EXPECT_GT(with.stats.apart_triangles, 0u);
  EXPECT_TRUE(analyzeTopology(pts.size(), with.triangles).isManifold());
  pcl_ecs::eval::MeshDistance d_plain, d_with;
  ASSERT_TRUE(toReference(s, plain.triangles, d_plain));
  ASSERT_TRUE(toReference(s, with.triangles, d_with));
  std::printf("pinion 10%%: %zu apart triangles; mesh to reference mean %.3g L (max %.3g L) with radii, %.3g L (%.3g L) "
              "without\n",
              with.stats.apart_triangles, d_with.to_reference_mean, d_with.to_reference_max, d_plain.to_reference_mean,
              d_plain.to_reference_max);
  EXPECT_LT(d_with.to_reference_mean, 0.95 * d_plain.to_reference_mean);
  EXPECT_LT(d_with.to_reference_max, 0.9 * d_plain.to_reference_max);
}

TEST(CoconeScan, TheSimplifiedGearsKeptPointsAreJudgedByTheirNearestBall)
{
  // The pinion scan simplified to 3%: its feature points and the points the gap bound kept have
  // radius 0. Left unknown (NaN), the cocones join some of them across the gear; judged by the
  // nearest ball's radius they do not, more triangles are refused as apart, and the mesh lies closer
  // to the reference: mean 0.87 × (bound 0.9), largest 0.98 × (bound 1), in one piece.
  SimplifiedScan s;
  if (!simplifiedPinion(3, s))
    GTEST_SKIP() << "shared data missing";
  ASSERT_TRUE(s.error.empty()) << s.error;
  const auto& pts = s.points;
  std::vector<double> unknown = s.radius;
  std::size_t kept = 0;
  for (double& r : unknown)
    if (r == 0.0)
    {
      r = std::numeric_limits<double>::quiet_NaN();
      ++kept;
    }
  ASSERT_GT(kept, 100u);
  const auto with = coconeReconstruct(pts, CoconeParameters(), s.radius);
  const auto without = coconeReconstruct(pts, CoconeParameters(), unknown);
  ASSERT_TRUE(with.ok() && without.ok());
  EXPECT_GT(with.stats.apart_triangles, without.stats.apart_triangles);
  const MeshTopology topo = analyzeTopology(pts.size(), with.triangles);
  EXPECT_TRUE(topo.isManifold());
  EXPECT_EQ(with.stats.components, 1u);
  pcl_ecs::eval::MeshDistance d_with, d_without;
  ASSERT_TRUE(toReference(s, with.triangles, d_with));
  ASSERT_TRUE(toReference(s, without.triangles, d_without));
  std::printf("pinion 3%%: %zu kept points; mesh to reference mean %.3g L (max %.3g L) judged by the nearest ball, "
              "%.3g L (%.3g L) unknown\n",
              kept, d_with.to_reference_mean, d_with.to_reference_max, d_without.to_reference_mean,
              d_without.to_reference_max);
  EXPECT_LT(d_with.to_reference_mean, 0.9 * d_without.to_reference_mean);
  EXPECT_LT(d_with.to_reference_max, d_without.to_reference_max);
  // Closed, with the gear's χ (0: one hole through it).
  EXPECT_TRUE(topo.isClosedManifold());
  EXPECT_EQ(topo.euler_characteristic, 0);
}

// ---- tunnels ------------------------------------------------------------------------------------

namespace
{
/// `n` points of the unit sphere as a scan (no sample_of: each goes to its nearest sample).
pcl_ecs::surface::ScanSupport sphereScan(std::size_t n, std::uint64_t seed)
{
  pcl_ecs::surface::ScanSupport scan;
  for (const auto& p : randomSphere(n, 1.0, seed))
    scan.points.push_back(p.cast<float>());
  return scan;
}
CoconeParameters withTunnels()
{
  CoconeParameters p;
  p.open_tunnels = true;
  return p;
}
}  // namespace

TEST(CoconeTunnels, TheTurbinesBoltHolesOpenWithItsScan)
{
  // The turbine (genus 11: the bore and ten bolt holes through its flange, χ −20) simplified to
  // 10%: each bolt hole is about one sample spacing across, and the walk caps it on both faces of
  // the flange (χ 0: the bore alone). With the scan, the ten pairs of caps span empty space and
  // are replaced by bands on the holes' walls: χ −20, closed, one piece. Without open_tunnels, or
  // without the scan, the mesh is the one without tunnels.
  SimplifiedScan s;
  if (!simplifiedScan("turbine", 10, s))
    GTEST_SKIP() << "shared data missing";
  ASSERT_TRUE(s.error.empty()) << s.error;
  const CoconeParameters on = withTunnels();
  const auto plain = coconeReconstruct(s.points, CoconeParameters(), s.radius, s.scan);
  const auto no_scan = coconeReconstruct(s.points, on, s.radius);
  const auto with = coconeReconstruct(s.points, on, s.radius, s.scan);
  ASSERT_TRUE(plain.ok() && no_scan.ok() && with.ok());
  EXPECT_EQ(plain.triangles, no_scan.triangles);
  EXPECT_EQ(plain.stats.opened_tunnels, 0u);
  const MeshTopology before = analyzeTopology(s.points.size(), plain.triangles);
  EXPECT_TRUE(before.isClosedManifold());
  EXPECT_EQ(before.euler_characteristic, 0);
  const MeshTopology after = analyzeTopology(s.points.size(), with.triangles);
  EXPECT_EQ(with.stats.opened_tunnels, 10u);
  EXPECT_GT(with.stats.tunnel_triangles, 0u);
  EXPECT_TRUE(after.isClosedManifold());
  EXPECT_TRUE(after.consistently_oriented);
  EXPECT_EQ(after.components, 1u);
  EXPECT_EQ(after.euler_characteristic, -20);
  // Each scan point given to its nearest sample instead of the filter's own: the same ten.
  pcl_ecs::surface::ScanSupport nearest = s.scan;
  nearest.sample_of.clear();
  const auto by_nearest = coconeReconstruct(s.points, on, s.radius, nearest);
  ASSERT_TRUE(by_nearest.ok());
  EXPECT_EQ(by_nearest.stats.opened_tunnels, 10u);
  EXPECT_EQ(analyzeTopology(s.points.size(), by_nearest.triangles).euler_characteristic, -20);
  // One thread or several: the same triangles.
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const auto serial = coconeReconstruct(s.points, on, s.radius, s.scan);
  omp_set_num_threads(threads);
  EXPECT_EQ(serial.triangles, with.triangles);
  // pcl_ecs::Cocone with the scan, its samples numbered like the input cloud (here behind a junk
  // point each, used through the indices): the same mesh.
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  auto indices = std::make_shared<pcl::Indices>();
  std::vector<double> radius;
  pcl_ecs::surface::ScanSupport scan = s.scan;
  for (std::size_t i = 0; i < s.points.size(); ++i)
  {
    cloud->push_back(pcl::PointXYZ(100.0f, 100.0f, 100.0f));
    radius.push_back(0.0);
    cloud->push_back(pcl_ecs_test::toPoint(s.points[i]));
    radius.push_back(s.radius[i]);
    indices->push_back(static_cast<pcl::index_t>(2 * i + 1));
  }
  for (std::int64_t& o : scan.sample_of)
    o = o >= 0 ? 2 * o + 1 : -1;
  pcl_ecs::Cocone<pcl::PointXYZ> cocone;
  cocone.setInputCloud(cloud);
  cocone.setIndices(indices);
  cocone.setSampleRadii(radius);
  cocone.setScanSupport(scan);
  cocone.setParameters(on);
  pcl::PolygonMesh mesh;
  cocone.reconstruct(mesh);
  ASSERT_TRUE(cocone.getLastError().empty()) << cocone.getLastError();
  EXPECT_EQ(cocone.getStats().opened_tunnels, 10u);
  ASSERT_EQ(mesh.polygons.size(), with.triangles.size());
  for (std::size_t t = 0; t < with.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(mesh.polygons[t].vertices[k], 2 * with.triangles[t][k] + 1);
  // The same class on the simplified points alone (no indices: the scan's map used as it is).
  auto alone = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  for (const auto& p : s.points)
    alone->push_back(pcl_ecs_test::toPoint(p));
  pcl_ecs::Cocone<pcl::PointXYZ> plain_cocone;
  plain_cocone.setInputCloud(alone);
  plain_cocone.setSampleRadii(s.radius);
  plain_cocone.setScanSupport(s.scan);
  plain_cocone.setParameters(on);
  plain_cocone.reconstruct(mesh);
  ASSERT_TRUE(plain_cocone.getLastError().empty()) << plain_cocone.getLastError();
  ASSERT_EQ(mesh.polygons.size(), with.triangles.size());
  for (std::size_t t = 0; t < with.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(mesh.polygons[t].vertices[k], with.triangles[t][k]);
}

TEST(CoconeTunnels, ASurfaceWithoutTunnelsIsLeftAsItIs)
{
  // A sphere sampled by 2,000 points, its scan 20,000 more points of it: no patch spans empty
  // space, so the mesh is the same triangle for triangle.
  const auto samples = randomSphere(2000, 1.0, 5);
  const pcl_ecs::surface::ScanSupport scan = sphereScan(20000, 6);
  const CoconeParameters on = withTunnels();
  const auto plain = coconeReconstruct(samples);
  const auto with = coconeReconstruct(samples, on, {}, scan);
  ASSERT_TRUE(plain.ok() && with.ok());
  EXPECT_EQ(with.stats.opened_tunnels, 0u);
  EXPECT_EQ(plain.triangles, with.triangles);
}

TEST(CoconeTunnels, AScanWhoseSamplesDoNotMatchIsRefused)
{
  const auto samples = randomSphere(500, 1.0, 7);
  pcl_ecs::surface::ScanSupport scan = sphereScan(3000, 8);
  const CoconeParameters on = withTunnels();
  scan.sample_of.assign(10, 0);  // not one per scan point
  auto r = coconeReconstruct(samples, on, {}, scan);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.error.find("sample_of has 10 entries for 3000 scan points"), std::string::npos) << r.error;
  scan.sample_of.assign(3000, 0);
  scan.sample_of[17] = 500;  // there are 500 samples: 0..499
  r = coconeReconstruct(samples, on, {}, scan);
  EXPECT_FALSE(r.ok());
  EXPECT_NE(r.error.find("sample_of[17] = 500 names no sample"), std::string::npos) << r.error;
  // A non-finite scan point is skipped, not an error.
  scan.sample_of.clear();
  scan.points[3] = Eigen::Vector3f(std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f);
  EXPECT_TRUE(coconeReconstruct(samples, on, {}, scan).ok());
}

// ---- watertight ----------------------------------------------------------------------------------

namespace
{
/// The sphere cut open below z = −0.5 (as in CappedSphereKeepsItsOpening).
std::vector<Eigen::Vector3d> cappedSphere(std::size_t n, std::uint64_t seed)
{
  std::vector<Eigen::Vector3d> pts;
  for (const auto& p : randomSphere(n, 1.0, seed))
    if (p.z() > -0.5)
      pts.push_back(p);
  return pts;
}
}  // namespace

TEST(CoconeWatertight, HolesAreSealed)
{
  // Small holes in a closed surface are bridged by Cocone itself (they are still sampled at the
  // scale of the local feature size); an opening like the capped sphere's stays open by default
  // and is sealed by the option.
  const auto pts = cappedSphere(12000, 11);
  const auto open = coconeReconstruct(pts);
  ASSERT_TRUE(open.ok()) << open.error;
  const MeshTopology to = analyzeTopology(pts.size(), open.triangles);
  EXPECT_EQ(to.boundary_loops, 1u);

  CoconeParameters p;
  p.watertight = true;
  const auto closed = coconeReconstruct(pts, p);
  ASSERT_TRUE(closed.ok()) << closed.error;
  const MeshTopology tc = analyzeTopology(pts.size(), closed.triangles);
  EXPECT_TRUE(tc.isClosedManifold()) << "boundary " << tc.boundary_edges << " nm edges " << tc.nonmanifold_edges
                                     << " nm vertices " << tc.nonmanifold_vertices;
  EXPECT_EQ(tc.euler_characteristic, 2);  // a sphere again
  EXPECT_EQ(tc.components, 1u);
  EXPECT_EQ(tc.used_vertices, to.used_vertices);
  EXPECT_EQ(closed.stats.sealed_loops, 1u);
  // Orientation: the seal (triangles spanning the cut) faces down, the rest away from the centre.
  std::set<Triangle> before;
  for (Triangle t : open.triangles)
  {
    std::sort(t.begin(), t.end());
    before.insert(t);
  }
  std::size_t seal = 0, wrong = 0;
  for (const Triangle& tri : closed.triangles)
  {
    Triangle key = tri;
    std::sort(key.begin(), key.end());
    const Eigen::Vector3d nrm = (pts[tri[1]] - pts[tri[0]]).cross(pts[tri[2]] - pts[tri[0]]);
    const Eigen::Vector3d c = (pts[tri[0]] + pts[tri[1]] + pts[tri[2]]) / 3.0;
    const bool is_seal = !before.count(key);  // the triangles the option added
    seal += is_seal;
    const bool bad = is_seal ? (nrm.z() >= 0) : (nrm.dot(c) <= 0);
    wrong += bad;

  }
  EXPECT_GT(seal, 0u);
  EXPECT_EQ(wrong, 0u);
}

TEST(CoconeWatertight, ClosedInputsStayTheSame)
{
  // On a sphere and a torus the Cocone surface is already closed: the watertight option gives the
  // same triangles.
  for (const auto& pts : {randomSphere(3000, 1.0, 8), randomTorus(6000, 1.0, 0.35, 8)})
  {
    CoconeParameters p;
    p.watertight = true;
    auto a = coconeReconstruct(pts).triangles, b = coconeReconstruct(pts, p).triangles;
    auto canon = [](std::vector<Triangle>& v) {
      for (auto& t : v)
        std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
      std::sort(v.begin(), v.end());
    };
    canon(a);
    canon(b);
    EXPECT_EQ(a, b);
  }
}

TEST(CoconeWatertight, BunnyBecomesClosed)
{
  pcl::PointCloud<pcl::PointXYZ> cloud;
  if (pcl::io::loadPCDFile(pcl_ecs_test::sharedData("bunny.pcd"), cloud) != 0)
    GTEST_SKIP() << "shared data missing";
  std::vector<Eigen::Vector3d> pts;
  for (const auto& q : cloud)
    pts.emplace_back(q.x, q.y, q.z);
  CoconeParameters p;
  p.watertight = true;
  const auto r = coconeReconstruct(pts, p);
  ASSERT_TRUE(r.ok()) << r.error;
  const MeshTopology t = analyzeTopology(pts.size(), r.triangles);
  std::printf("bunny watertight: %zu triangles, %zu used of %zu, %zu loops sealed, chi %ld, %zu components\n",
              t.triangles, t.used_vertices, pts.size(), r.stats.sealed_loops, t.euler_characteristic, t.components);
  EXPECT_TRUE(t.isClosedManifold()) << "boundary " << t.boundary_edges << " nm edges " << t.nonmanifold_edges
                                    << " nm vertices " << t.nonmanifold_vertices;
  EXPECT_GE(static_cast<double>(t.used_vertices), 0.99 * static_cast<double>(pts.size()));
}
