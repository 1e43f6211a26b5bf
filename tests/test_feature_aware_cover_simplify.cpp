// The filter as a user sees it: analytic shapes with exact expectations, the shared scans, and
// the pcl::Filter contract.
#include <pcl_ecs/eval/quality_metrics.h>
#include <pcl_ecs/feature_aware_cover_simplify.h>

#include "synthetic_shapes.h"

#include <cmath>
#include <limits>
#include <set>
#include <array>
#include <string>

#include <gtest/gtest.h>
#include <pcl/common/common.h>
#include <pcl/io/pcd_io.h>
#include <pcl/search/kdtree.h>

using namespace pcl_ecs_test;
using Filter = pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ>;

namespace
{
Cloud::Ptr loadShared(const std::string& name)
{
  auto c = std::make_shared<Cloud>();
  if (pcl::io::loadPCDFile(sharedData(name), *c) < 0)
    ADD_FAILURE() << "cannot read " << sharedData(name);
  return c;
}

Cloud::Ptr scaledCopy(const Cloud& c, float factor)
{
  auto out = std::make_shared<Cloud>(c);
  for (auto& p : *out)
    p.getVector3fMap() *= factor;
  return out;
}

/// The cloud × k, computed in double (for factors float cannot hold well: 1e-24, 1e30).
Cloud::Ptr scaledByDouble(const Cloud& c, double k)
{
  auto out = std::make_shared<Cloud>();
  for (const auto& p : c)
    out->push_back(pcl::PointXYZ(static_cast<float>(p.x * k), static_cast<float>(p.y * k), static_cast<float>(p.z * k)));
  return out;
}

Cloud run(const Cloud::Ptr& in, Filter& f)
{
  Cloud out;
  f.setInputCloud(in);
  f.filter(out);
  return out;
}

/// How many input points each output point stands for (Result::input_to_output), checking that the
/// mapping is total and in range; empty when it is not.
std::vector<std::size_t> pointsStoodFor(const pcl_ecs::Result& r, std::size_t input_size, std::size_t output_size)
{
  std::vector<std::size_t> count(output_size, 0);
  EXPECT_EQ(r.input_to_output.size(), input_size);
  if (r.input_to_output.size() != input_size)
    return {};
  for (std::size_t i = 0; i < input_size; ++i)
  {
    const std::int64_t o = r.input_to_output[i];
    EXPECT_TRUE(o >= 0 && o < static_cast<std::int64_t>(output_size)) << "input point " << i << " maps to " << o;
    if (!(o >= 0 && o < static_cast<std::int64_t>(output_size)))
      return {};
    ++count[static_cast<std::size_t>(o)];
  }
  return count;
}
}  // namespace

TEST(Filter, PlaneHasNoFeaturesAndRepresentativesOnThePlane)
{
  auto cloud = randomPlane(10000, 2.0, 1);
  Filter f;
  const Cloud out = run(cloud, f);
  const auto& r = f.getResult();
  ASSERT_TRUE(r.error.empty()) << r.error;
  EXPECT_EQ(r.summary.feature_points, 0u);
  EXPECT_LT(r.summary.mean_abs_curvature, 1e-6);
  const double L = r.summary.bbox_diagonal;
  ASSERT_GT(out.size(), 0u);
  for (const auto& p : out)
    EXPECT_LE(std::abs(p.z), 1e-6 * L);
  EXPECT_LT(out.size(), cloud->size() / 5);
}

// The summary counts the balls too rough for a point of their own (Parameters::max_roughness):
// some on a plane half covered by a scattered layer, among the balls that use their centre; none
// on a clean plane, and none when the limit is off. The limit leaves the cover as it is.
TEST(Filter, SummaryCountsRoughBalls)
{
  const auto rough = halfRoughPlane(8000, 0.0005, 0.03, 6);
  Filter a, b, c;
  run(rough, a);
  b.setMaxRoughness(10.0);
  run(rough, b);
  run(randomPlane(8000, 1.0, 2), c);
  const auto& sa = a.getResult().summary;
  const auto& sb = b.getResult().summary;
  EXPECT_GT(sa.rough_balls, sa.balls / 50);  // 163 of 4,050 (many rough points are features)
  EXPECT_LE(sa.rough_balls, sa.centre_fallbacks);
  EXPECT_EQ(sb.rough_balls, 0u);
  EXPECT_EQ(sa.balls, sb.balls);
  EXPECT_GT(sa.centre_fallbacks, sb.centre_fallbacks);
  EXPECT_EQ(c.getResult().summary.rough_balls, 0u);
}

TEST(Filter, SphereCurvatureAndRepresentatives)
{
  const double rho = 1.5;
  auto cloud = fibonacciSphere(30000, rho, 0.0, 1, Eigen::Vector3d(10, -4, 2));
  Filter f;
  f.setErrorThreshold(5e-4);
  const Cloud out = run(cloud, f);
  const auto& r = f.getResult();
  ASSERT_TRUE(r.error.empty());
  EXPECT_NEAR(r.summary.mean_abs_curvature, 1.0 / rho, 0.03 / rho);
  EXPECT_EQ(r.summary.feature_points, 0u);  // a sphere has no sharp feature
  const double L = r.summary.bbox_diagonal;
  for (const auto& b : r.balls)
  {
    // E is a weighted RMS distance to the tangent planes; the representative is within a few
    // T_err·L of the sphere (the worst representatives sit at about 1.1 T_err·L).
    const double dist = std::abs((b.representative - Eigen::Vector3d(10, -4, 2)).norm() - rho);
    EXPECT_LT(dist, 2.0 * b.tolerance * L);
  }
}

// Cube of side 2 with 61 samples per edge (spacing h = 1/30) and noise of 2% of h along the
// normals: at the default α, ≥ 90% of the samples within one spacing of an edge are features and
// ≤ 5% of the samples farther than 3 spacings are.
TEST(Filter, CubeEdgesAreFeatures)
{
  const double a = 2.0;
  const int m = 151;
  const double h = a / (m - 1);
  auto cloud = cubeSurface(m, a, 0.02 * h, 3);
  Filter f;
  const Cloud out = run(cloud, f);
  const auto& r = f.getResult();
  ASSERT_TRUE(r.error.empty());
  std::vector<std::uint8_t> is_feature(cloud->size(), 0);
  for (std::size_t o = 0; o < out.size(); ++o)
    if (r.labels[o] == pcl_ecs::PointLabel::Feature)
      is_feature[static_cast<std::size_t>(r.source_index[o])] = 1;
  std::size_t near = 0, near_f = 0, far = 0, far_f = 0;
  for (std::size_t i = 0; i < cloud->size(); ++i)
  {
    const double d = distanceToCubeEdge((*cloud)[i].getVector3fMap().cast<double>(), a);
    if (d <= 1.01 * h)
    {
      ++near;
      near_f += is_feature[i];
    }
    else if (d > 3.0 * h)
    {
      ++far;
      far_f += is_feature[i];
    }
  }
  EXPECT_GE(near_f, 0.9 * near) << near_f << " of " << near;
  EXPECT_LE(far_f, 0.05 * far) << far_f << " of " << far;
}

// Scaling by a power of two is exact in floating point, so the normalized error must give the
// very same decisions: same size, same representatives scaled, bit for bit.
TEST(Filter, NormalizedErrorIsScaleFreeExactly)
{
  auto cloud = loadShared("bunny.pcd");
  auto scaled = scaledCopy(*cloud, 1024.0f);
  Filter a, b;
  const Cloud oa = run(cloud, a), ob = run(scaled, b);
  ASSERT_GT(oa.size(), 100u);
  ASSERT_EQ(oa.size(), ob.size());
  EXPECT_EQ(a.getResult().summary.feature_points, b.getResult().summary.feature_points);
  for (std::size_t i = 0; i < oa.size(); ++i)
    ASSERT_EQ(oa[i].getVector3fMap() * 1024.0f, ob[i].getVector3fMap()) << i;
}

// Scaling by 1000 rounds every coordinate; decisions near a threshold may flip, nothing more:
// sizes within 0.5% and 98% of the representatives matched by a scaled one within 1e-4·L.
TEST(Filter, NormalizedErrorIsScaleFreeBy1000)
{
  auto cloud = loadShared("bunny.pcd");
  auto scaled = scaledCopy(*cloud, 1000.0f);
  Filter a, b;
  const Cloud oa = run(cloud, a), ob = run(scaled, b);
  ASSERT_GT(oa.size(), 100u);
  EXPECT_NEAR(static_cast<double>(ob.size()), static_cast<double>(oa.size()), 0.005 * oa.size());
  auto ob_down = scaledCopy(ob, 1.0f / 1000.0f);
  pcl::search::KdTree<pcl::PointXYZ> tree;
  tree.setInputCloud(ob_down);
  const double L = a.getResult().summary.bbox_diagonal;
  std::size_t matched = 0;
  pcl::Indices idx(1);
  std::vector<float> d2(1);
  for (const auto& p : oa)
    if (tree.nearestKSearch(p, 1, idx, d2) == 1 && std::sqrt(d2[0]) < 1e-4 * L)
      ++matched;
  EXPECT_GE(matched, oa.size() * 98 / 100);
}

TEST(Filter, LargerTerrFewerPointsLargerAlphaFewerFeatures)
{
  for (const char* name : {"bunny.pcd", "fandisk_scan.pcd", "bun000_rangescan.pcd"})
  {
    auto cloud = loadShared(name);
    std::size_t prev_size = std::numeric_limits<std::size_t>::max();
    for (double t : {2e-4, 1e-3, 5e-3})
    {
      Filter f;
      f.setErrorThreshold(t);
      f.setRadiusCapFactor(50.0);  // let T_err, not the cap, decide
      const std::size_t size = run(cloud, f).size();
      EXPECT_LT(size, prev_size) << name << " T_err " << t;
      prev_size = size;
    }
    std::size_t prev_features = std::numeric_limits<std::size_t>::max();
    for (double alpha : {2.5, 3.5, 4.5, 6.0})
    {
      Filter f;
      f.setFeatureFactor(alpha);
      run(cloud, f);
      const std::size_t features = f.getResult().summary.feature_points;
      EXPECT_LT(features, prev_features) << name << " alpha " << alpha;
      prev_features = features;
    }
  }
}

// A target size thins the feature points along the edges; a thinned-out one the gap bound made an
// output point of its own maps to that point, the others to the kept feature point standing for them.
TEST(Filter, ThinnedOutFeaturePointsMapToTheOutputStandingForThem)
{
  // 1% of the fandisk; 0.5% of the room scan, whose points are all stored twice (1% of its places).
  for (const auto& [file, target] : {std::pair<const char*, std::size_t>{"fandisk_scan.pcd", 1200}, {"room_scan2.pcd", 565}})
  {
    SCOPED_TRACE(file);
    auto cloud = loadShared(file);
    Filter f;
    f.setTargetSize(target);
    const Cloud out = run(cloud, f);
    const auto& r = f.getResult();
    ASSERT_TRUE(r.error.empty()) << r.error;
    ASSERT_GT(r.summary.thinned_features, 0u);
    const std::vector<std::size_t> replaced = pointsStoodFor(r, cloud->size(), out.size());
    ASSERT_EQ(replaced.size(), out.size());
    std::size_t own_points = 0;
    auto mapsToItself = [&](std::size_t o) {
      return r.input_to_output[static_cast<std::size_t>(r.source_index[o])] == static_cast<std::int64_t>(o);
    };
    for (std::size_t o = 0; o < out.size(); ++o)
    {
      if (r.labels[o] == pcl_ecs::PointLabel::Feature)
      {
        EXPECT_TRUE(mapsToItself(o));
        EXPECT_GE(replaced[o], 1u);
        continue;
      }
      const auto& b = r.balls[static_cast<std::size_t>(r.ball_of_output[o])];
      // (a ball's `replaced` counts coincident input points once: the room scan has them)
      if (r.summary.merged_points == 0)
        EXPECT_EQ(replaced[o], b.replaced);
      if (b.isOwnPoint())
      {
        ++own_points;
        EXPECT_TRUE(mapsToItself(o));
      }
    }
    EXPECT_GT(own_points, 0u);
  }
}

TEST(Filter, MappingIsTotalAndErrorsWithinTolerance)
{
  auto cloud = loadShared("bunny.pcd");
  Filter f;
  const Cloud out = run(cloud, f);
  const auto& r = f.getResult();
  const std::vector<std::size_t> replaced = pointsStoodFor(r, cloud->size(), out.size());
  ASSERT_EQ(replaced.size(), out.size());
  ASSERT_EQ(r.labels.size(), out.size());
  for (std::size_t o = 0; o < out.size(); ++o)
  {
    if (r.labels[o] == pcl_ecs::PointLabel::Feature)
    {
      EXPECT_EQ(replaced[o], 1u);
      EXPECT_EQ(r.input_to_output[static_cast<std::size_t>(r.source_index[o])], static_cast<std::int64_t>(o));
    }
    else
    {
      const auto& b = r.balls[static_cast<std::size_t>(r.ball_of_output[o])];
      EXPECT_EQ(b.output_index, o);
      EXPECT_EQ(replaced[o], b.replaced);
      EXPECT_LE(b.error, b.tolerance);
    }
  }
  EXPECT_EQ(r.summary.output_points, out.size());
  EXPECT_LE(r.summary.max_error, 2.0 * f.getErrorThreshold());  // adaptive factor 2
  EXPECT_GT(r.summary.timings.total, 0.0);
}

TEST(Filter, NonFinitePointsAreDroppedAndOrganisedBecomesUnorganised)
{
  auto plane = gridPlane(60, 0.01);
  auto cloud = std::make_shared<Cloud>(*plane);
  cloud->width = 60;
  cloud->height = 60;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (std::size_t i = 0; i < cloud->size(); i += 7)
    (*cloud)[i].x = nan;
  (*cloud)[3].z = std::numeric_limits<float>::infinity();
  cloud->is_dense = false;
  Filter f;
  const Cloud out = run(cloud, f);
  ASSERT_GT(out.size(), 0u);
  EXPECT_EQ(out.height, 1u);
  EXPECT_EQ(out.width, out.size());
  EXPECT_TRUE(out.is_dense);
  for (const auto& p : out)
    EXPECT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
  const auto& r = f.getResult();
  EXPECT_EQ(r.input_to_output[0], -1);
  EXPECT_EQ(r.input_to_output[3], -1);
  EXPECT_GE(r.input_to_output[1], 0);
  EXPECT_EQ(r.summary.finite_points, 3600u - 515u - 1u);
}

TEST(Filter, EmptyAndTooSmallInputsGiveEmptyOutputAndAnError)
{
  Filter f;
  Cloud out;
  out.push_back(pcl::PointXYZ(1, 2, 3));  // stale output must be cleared
  f.setInputCloud(std::make_shared<Cloud>());
  f.filter(out);
  EXPECT_TRUE(out.empty());
  EXPECT_FALSE(f.getResult().error.empty());

  auto small = gridPlane(4, 1.0);  // 16 points, K = 16 needs 17
  out.push_back(pcl::PointXYZ(1, 2, 3));
  f.setInputCloud(small);
  f.filter(out);
  EXPECT_TRUE(out.empty());
  EXPECT_NE(f.getResult().error.find("K = 16"), std::string::npos) << f.getResult().error;

  auto nans = std::make_shared<Cloud>(*gridPlane(10, 1.0));
  for (auto& p : *nans)
    p.y = std::numeric_limits<float>::quiet_NaN();
  nans->is_dense = false;
  f.setInputCloud(nans);
  f.filter(out);
  EXPECT_TRUE(out.empty());
  EXPECT_NE(f.getResult().error.find("no finite points"), std::string::npos);
}

TEST(Filter, DegenerateCloudsAreRefusedCleanly)
{
  Filter f;
  Cloud out;
  auto same = std::make_shared<Cloud>();
  for (int i = 0; i < 50; ++i)
    same->push_back(pcl::PointXYZ(1, 1, 1));
  f.setInputCloud(same);
  f.filter(out);
  EXPECT_TRUE(out.empty());
  EXPECT_NE(f.getResult().error.find("identical"), std::string::npos);

  auto line = std::make_shared<Cloud>();
  for (int i = 0; i < 50; ++i)
    line->push_back(pcl::PointXYZ(i * 0.1f, i * 0.2f, 3.0f));
  f.setInputCloud(line);
  f.filter(out);
  EXPECT_TRUE(out.empty());
  EXPECT_NE(f.getResult().error.find("line"), std::string::npos);
}

TEST(Filter, BadParameterGivesEmptyOutput)
{
  auto cloud = fibonacciSphere(2000, 1.0);
  for (int which = 0; which < 6; ++which)
  {
    Filter f;
    if (which == 0) f.setErrorThreshold(-1.0);
    if (which == 1) f.setFeatureFactor(std::numeric_limits<double>::quiet_NaN());
    if (which == 2) f.setNeighborhoodSize(0);
    if (which == 3) f.setUseInputNormals(true);  // PointXYZ carries no normals
    if (which == 4) f.setRepresentativeCutoff(0.0);
    if (which == 5) f.setMaxRoughness(-1.0);
    Cloud out;
    out.push_back(pcl::PointXYZ(0, 0, 0));
    f.setInputCloud(cloud);
    f.filter(out);
    EXPECT_TRUE(out.empty()) << which;
    EXPECT_FALSE(f.getResult().error.empty()) << which;
  }
}

TEST(Filter, HonoursIndicesKeepsHeaderAndWorksInPlace)
{
  auto cloud = fibonacciSphere(6000, 1.0);
  cloud->header.frame_id = "scanner";
  cloud->header.stamp = 12345;
  auto indices = std::make_shared<pcl::Indices>();
  for (int i = 0; i < 6000; ++i)
    if ((*cloud)[static_cast<std::size_t>(i)].z > 0.0f)
      indices->push_back(i);
  Filter f;
  f.setInputCloud(cloud);
  f.setIndices(indices);
  Cloud out;
  f.filter(out);
  ASSERT_GT(out.size(), 0u);
  EXPECT_EQ(out.header.frame_id, "scanner");
  EXPECT_EQ(out.header.stamp, 12345u);
  for (const auto& p : out)
    EXPECT_GT(p.z, -0.05f);  // only the upper half was used
  EXPECT_EQ(f.getResult().input_to_output[static_cast<std::size_t>(3000 + 100)] , f.getResult().input_to_output[static_cast<std::size_t>(3000 + 100)]);
  for (int i = 0; i < 6000; ++i)
    if ((*cloud)[static_cast<std::size_t>(i)].z <= 0.0f)
      EXPECT_EQ(f.getResult().input_to_output[static_cast<std::size_t>(i)], -1);

  // In place: filter(*input) gives the same points as into another cloud.
  Filter g;
  auto copy = std::make_shared<Cloud>(*cloud);
  g.setInputCloud(copy);
  g.setIndices(indices);
  g.filter(*copy);
  ASSERT_EQ(copy->size(), out.size());
  for (std::size_t i = 0; i < out.size(); ++i)
    EXPECT_EQ((*copy)[i].getVector3fMap(), out[i].getVector3fMap());
  EXPECT_EQ(copy->header.frame_id, "scanner");
}

TEST(Filter, SameSeedSameOutputWhateverTheThreadCount)
{
  auto cloud = loadShared("fandisk_scan.pcd");
  Filter one, all, again;
  one.setNumberOfThreads(1);
  all.setNumberOfThreads(0);
  again.setNumberOfThreads(2);
  const Cloud a = run(cloud, one), b = run(cloud, all), c = run(cloud, again);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.size(), c.size());
  for (std::size_t i = 0; i < a.size(); ++i)
  {
    // Bit for bit.
    ASSERT_EQ(std::memcmp(&a[i], &b[i], sizeof(pcl::PointXYZ)), 0) << i;
    ASSERT_EQ(std::memcmp(&a[i], &c[i], sizeof(pcl::PointXYZ)), 0) << i;
  }
  Filter other;
  other.setSeed(1234);
  const Cloud d = run(cloud, other);
  bool differs = d.size() != a.size();
  for (std::size_t i = 0; !differs && i < a.size(); ++i)
    differs = a[i].getVector3fMap() != d[i].getVector3fMap();
  EXPECT_TRUE(differs);
}

TEST(Filter, TargetSizeWithinOnePercent)
{
  auto cloud = loadShared("bunny.pcd");
  for (std::size_t target : {3600u, 1100u})
  {
    Filter f;
    f.setTargetSize(target);
    const Cloud out = run(cloud, f);
    EXPECT_NEAR(static_cast<double>(out.size()), static_cast<double>(target), 0.01 * target);
    EXPECT_GT(f.getResult().summary.target_iterations, 1);
  }
}

// A target cap so tight that it, not T_err, sets the count: raising T stops changing the output,
// the search notices (one ×4 step with no change) and widens the cap at once, instead of bisecting
// towards T = 1 (which took 40 covers on the terrain scan).
TEST(Filter, TargetSearchLeavesABindingCapQuickly)
{
  auto cloud = loadShared("bunny.pcd");
  Filter f;
  f.setTargetSize(1100);
  f.setTargetRadiusCap(0.8);
  const Cloud out = run(cloud, f);
  const auto& s = f.getResult().summary;
  EXPECT_NEAR(static_cast<double>(out.size()), 1100.0, 11.0);
  EXPECT_GT(s.radius_cap_factor, 0.8 * std::sqrt(static_cast<double>(cloud->size() - s.feature_points) /
                                                 (16.0 * (1100.0 - static_cast<double>(s.feature_points)))));
  EXPECT_LE(s.target_iterations, 25);
}

TEST(Filter, TargetCapFollowsTheTargetAndFallsBackNearTheInputSize)
{
  auto cloud = loadShared("bunny.pcd");
  const std::size_t n = cloud->size();
  // 10%: the cap is 2.5 × the spacing the target implies, and the size is reached with it.
  {
    Filter f;
    f.setTargetSize(n / 10);
    const Cloud out = run(cloud, f);
    const auto& s = f.getResult().summary;
    EXPECT_NEAR(static_cast<double>(out.size()), n / 10.0, 0.01 * n / 10.0);
    const double balls_wanted = static_cast<double>(n / 10) - static_cast<double>(s.feature_points);
    const double implied = std::sqrt(static_cast<double>(n - s.feature_points) / (16.0 * balls_wanted));
    EXPECT_NEAR(s.radius_cap_factor, 2.5 * implied, 1e-12);
    // Off: the plain cap.
    Filter g;
    g.setTargetSize(n / 10);
    g.setTargetRadiusCap(0.0);
    run(cloud, g);
    EXPECT_DOUBLE_EQ(g.getResult().summary.radius_cap_factor, 5.0);
  }
  // 80%: the target cap (0.7 neighbourhood radii) is too tight to merge enough points; the search
  // widens it (×1.5 steps, at most the plain cap) and still lands within 1%.
  {
    Filter f;
    f.setTargetSize(n * 8 / 10);
    const Cloud out = run(cloud, f);
    EXPECT_NEAR(static_cast<double>(out.size()), 0.8 * n, 0.01 * 0.8 * n);
    const double implied = 2.5 * std::sqrt(static_cast<double>(n - f.getResult().summary.feature_points) /
                                           (16.0 * (0.8 * n - f.getResult().summary.feature_points)));
    EXPECT_GT(f.getResult().summary.radius_cap_factor, implied);
    EXPECT_LE(f.getResult().summary.radius_cap_factor, 5.0);
  }
}

namespace
{
/// Largest distance from a point of `cloud` to its nearest point of `out`.
double coverageMax(const Cloud::Ptr& cloud, const Cloud& out)
{
  pcl::search::KdTree<pcl::PointXYZ> tree;
  tree.setInputCloud(out.makeShared());
  pcl::Indices idx;
  std::vector<float> d2;
  double worst = 0.0;
  for (const auto& p : *cloud)
    if (tree.nearestKSearch(p, 1, idx, d2) == 1)
      worst = std::max(worst, std::sqrt(static_cast<double>(d2[0])));
  return worst;
}
}  // namespace

// The gap bound (gap_fill.h): no input point farther than max_gap from the output, in the T_err
// mode (here 0.6 × the cap: the default 1 finds no gap on the bunny) and in the target-size mode
// (default 0.6 × the target's cap; the search keeps the size within 1%); off, the paper's cover
// leaves points farther than that.
TEST(Filter, NoPointFartherThanTheGapFromTheOutput)
{
  auto cloud = loadShared("bunny.pcd");
  for (const std::size_t target : {std::size_t{0}, cloud->size() / 10})
  {
    Filter f;
    f.setTargetSize(target);
    if (target == 0)
      f.setMaxGapFactor(0.6);
    const Cloud out = run(cloud, f);
    const auto& s = f.getResult().summary;
    ASSERT_GT(s.max_gap, 0.0);
    EXPECT_GT(s.gap_points, 0u) << "the bound must be exercised";
    EXPECT_LE(coverageMax(cloud, out), s.max_gap * (1.0 + 1e-6)) << "target " << target;
    if (target > 0)
      EXPECT_NEAR(static_cast<double>(out.size()), static_cast<double>(target), 0.01 * target);

    Filter off;
    off.setTargetSize(target);
    off.setMaxGapFactor(0.0);
    off.setTargetGapFactor(0.0);
    const Cloud paper = run(cloud, off);
    EXPECT_EQ(off.getResult().summary.gap_points, 0u);
    EXPECT_GT(coverageMax(cloud, paper), s.max_gap) << "target " << target;
  }
}

// On the bunny at 10% the gap points keep the size out of reach at the target's cap, so the search
// widens the gap bound; once two searches show how the gap points fall, it takes several ×1.1
// steps at once, and a search at a cap already found saturated skips its 4T probe. The size is
// still within 1%, the bound wider than the default, and the trials (deterministic) at most 11:
// one ×1.1 step per search, each with its 4T probe, took 14; the covers run at most 6 (a widened
// gap bound reuses the cover).
TEST(Filter, TargetSearchWidensTheGapInFewCovers)
{
  auto cloud = loadShared("bunny.pcd");
  Filter f;
  f.setTargetSize(3600);
  const Cloud out = run(cloud, f);
  const auto& s = f.getResult().summary;
  EXPECT_NEAR(static_cast<double>(out.size()), 3600.0, 36.0);
  EXPECT_GT(s.max_gap, 1.05 * 0.6 * s.radius_cap_factor * s.neighborhood_radius) << "the gap bound was widened";
  EXPECT_LE(s.target_iterations, 11);
  EXPECT_LE(s.cover_passes, 6);
}

// Each cover predicts where the next should go (cover_size_model.h): on scans where the gap
// points bind at the start, the gap bound widens at the starting T_err and one predicted step
// reaches the size; a T_err whose cover is kept is tried on the way to a prediction (on the
// terrain at 3% the prediction from a saturated cover overshoots past one).
TEST(Filter, TargetSearchReachesTheSizeInFewCovers)
{
  struct Case
  {
    const char* name;
    std::size_t target;  // 10% or 3% of the distinct points (pcd_simplify --target-ratio)
    int max_passes;
  };
  for (const Case& c : {Case{"elephant_scan.pcd", 15000, 2}, Case{"fertility_scan.pcd", 4500, 2},
                        Case{"terrain_csite1_utm.pcd", 12899, 3}})
  {
    Filter f;
    f.setTargetSize(c.target);
    run(loadShared(c.name), f);
    const auto& s = f.getResult().summary;
    EXPECT_TRUE(s.target_reached) << c.name;
    EXPECT_LE(s.cover_passes, c.max_passes) << c.name;
  }
}

// The target-size search reuses covers (a gap bound widened at the same T and cap, a T tried
// before), stops probing T on a saturated cover and estimates trials far from the size from the
// cover's first colour: what it returns is exactly the plain run at the T, cap and gap bound it
// settled on, on shapes where the gap, the cap and T each decide, and in fewer covers than trials.
TEST(Filter, TargetSearchResultIsThePlainRunAtItsSettings)
{
  struct Case
  {
    const char* file;
    double ratio;
  };
  bool estimated = false;
  for (const Case& c : {Case{"bunny.pcd", 0.1}, Case{"bunny.pcd", 0.03}, Case{"fandisk_scan.pcd", 0.1},
                        Case{"terrain_csite2_utm.pcd", 0.1}})
  {
    SCOPED_TRACE(std::string(c.file) + " " + std::to_string(c.ratio));
    auto cloud = loadShared(c.file);
    const auto target = static_cast<std::size_t>(c.ratio * static_cast<double>(cloud->size()));
    Filter f;
    f.setTargetSize(target);
    const Cloud out = run(cloud, f);
    const auto& s = f.getResult().summary;
    EXPECT_NEAR(static_cast<double>(out.size()), static_cast<double>(target), 0.01 * static_cast<double>(target));
    EXPECT_LT(s.cover_passes, s.target_iterations) << "no cover was reused";
    EXPECT_LE(s.cover_passes + s.estimated_trials, s.target_iterations);
    estimated = estimated || s.estimated_trials > 0;
    Filter plain;
    plain.setErrorThreshold(s.error_threshold);
    plain.setRadiusCapFactor(s.radius_cap_factor);
    plain.setMaxGapFactor(s.max_gap / (s.radius_cap_factor * s.neighborhood_radius));
    plain.setFeatureSpacing(s.feature_spacing);
    const Cloud ref = run(cloud, plain);
    // The same points, less those a top-up added at the end (fillToCount).
    ASSERT_EQ(ref.size() + s.size_points, out.size());
    std::size_t same = 0;
    for (std::size_t i = 0; i < ref.size(); ++i)
      same += out[i].getVector3fMap() == ref[i].getVector3fMap() ? 1 : 0;
    EXPECT_EQ(same, ref.size());
  }
  EXPECT_TRUE(estimated) << "no trial was estimated from a first colour (the terrain at 10% has such steps)";
}

TEST(Filter, FeatureRepresentativeLabelsAndUtmCoordinates)
{
  auto cloud = loadShared("terrain_csite1_utm.pcd");
  ASSERT_GT(cloud->size(), 500000u);
  Filter f;
  const Cloud out = run(cloud, f);
  const auto& r = f.getResult();
  ASSERT_TRUE(r.error.empty()) << r.error;
  ASSERT_GT(out.size(), 0u);
  EXPECT_LT(out.size(), cloud->size() / 4);
  // Representatives stay within the input's bounding box grown by a ball radius: in the millions,
  // float rounding of a naive implementation moves points by metres.
  Eigen::Vector4f lo, hi;
  pcl::getMinMax3D(*cloud, lo, hi);
  for (const auto& b : r.balls)
  {
    EXPECT_LE((b.representative - b.centre).norm(), b.radius + 1e-3);
  }
  for (const auto& p : out)
  {
    EXPECT_GE(p.x, lo.x() - 50.0f);
    EXPECT_LE(p.x, hi.x() + 50.0f);
  }
}

TEST(Filter, ResultSaysWhetherTheTargetSizeWasReached)
{
  auto cloud = fibonacciSphere(20000, 1.0);
  pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ> f;
  f.setInputCloud(cloud);
  pcl::PointCloud<pcl::PointXYZ> out;
  f.setTargetSize(1000);
  f.filter(out);
  EXPECT_TRUE(f.getResult().summary.target_reached);
  EXPECT_EQ(f.getResult().summary.target_size, 1000u);
  EXPECT_NEAR(static_cast<double>(out.size()), 1000.0, 10.0);
  // Three points are not within 1% of any size the search can reach with the radius cap at its
  // plain value (a cap that follows the target may grow until three balls cover the sphere): the
  // closest size is given.
  f.setTargetSize(3);
  f.setTargetRadiusCap(0.0);
  f.filter(out);
  EXPECT_FALSE(f.getResult().summary.target_reached);
  EXPECT_EQ(f.getResult().summary.output_points, out.size());
  EXPECT_GT(out.size(), 3u);
  // T_err mode: no target, nothing to reach.
  f.setTargetSize(0);
  f.filter(out);
  EXPECT_TRUE(f.getResult().summary.target_reached);
  EXPECT_EQ(f.getResult().summary.target_size, 0u);
}

// Coincident points: a cloud stored twice is simplified as the cloud itself, point for point, and
// the copies map to the output point of the point they coincide with.
TEST(Filter, CoincidentPointsAreMergedIntoOne)
{
  auto once = fibonacciSphere(20000, 1.0, 0.002, 3);
  auto twice = std::make_shared<Cloud>(*once);
  *twice += *once;
  Filter a, b;
  Cloud out_a, out_b;
  a.setInputCloud(once);
  a.filter(out_a);
  b.setInputCloud(twice);
  b.filter(out_b);
  ASSERT_TRUE(b.getResult().error.empty()) << b.getResult().error;
  ASSERT_EQ(out_b.size(), out_a.size());
  for (std::size_t i = 0; i < out_a.size(); ++i)
    ASSERT_TRUE(out_a[i].x == out_b[i].x && out_a[i].y == out_b[i].y && out_a[i].z == out_b[i].z) << i;
  EXPECT_EQ(b.getResult().summary.merged_points, once->size());
  EXPECT_EQ(b.getResult().summary.finite_points, twice->size());
  EXPECT_EQ(a.getResult().summary.merged_points, 0u);
  const auto& map = b.getResult().input_to_output;
  for (std::size_t j = 0; j < once->size(); ++j)
    ASSERT_EQ(map[j + once->size()], map[j]) << j;
}

// A cloud concatenated with a copy of itself moved by one float ulp on every axis (what a
// re-export or a transform leaves of a duplicate): the copies are merged as coincident points, so
// the output is the cloud's own, in T_err mode and at a target size (it had 4.6× the features and
// a 10× larger T_err at the same size before): the same size within 1% and, measured against the
// cloud once, the same surface deviation, tangent offset and coverage within 2%.
TEST(Filter, PointsThatDifferByRoundingAreMerged)
{
  auto once = loadShared("bunny.pcd");
  auto twice = std::make_shared<Cloud>(*once);
  for (const auto& p : *once)
    twice->push_back(pcl::PointXYZ(std::nextafter(p.x, 1e9f), std::nextafter(p.y, 1e9f), std::nextafter(p.z, 1e9f)));
  for (std::size_t target : {0u, 3600u})
  {
    Filter a, b;
    a.setTargetSize(target);
    b.setTargetSize(target);
    const Cloud out_a = run(once, a), out_b = run(twice, b);
    const auto& s = b.getResult().summary;
    EXPECT_GE(static_cast<double>(s.merged_points), 0.99 * static_cast<double>(once->size())) << target;
    EXPECT_NEAR(static_cast<double>(out_b.size()), static_cast<double>(out_a.size()), 0.01 * out_a.size()) << target;
    EXPECT_NEAR(static_cast<double>(s.feature_points), static_cast<double>(a.getResult().summary.feature_points), 3.0)
        << target;
    pcl_ecs::eval::QualityMetrics qa, qb;
    ASSERT_TRUE(pcl_ecs::eval::evaluateQuality(*once, out_a, nullptr, qa));
    ASSERT_TRUE(pcl_ecs::eval::evaluateQuality(*once, out_b, nullptr, qb));
    EXPECT_NEAR(qb.surface_rms, qa.surface_rms, 0.02 * qa.surface_rms) << target;
    EXPECT_NEAR(qb.tangent_rms, qa.tangent_rms, 0.02 * qa.tangent_rms) << target;
    EXPECT_NEAR(qb.coverage_mean, qa.coverage_mean, 0.02 * qa.coverage_mean) << target;
    // The largest gap is one point's distance: the two runs' relaxed representatives (their covers
    // differ by the rounding) put it at 0.0284 and 0.0295 L on the bunny in the T_err mode (both below
    // the 0.0311 L of either run unrelaxed).
    EXPECT_NEAR(qb.coverage_max, qa.coverage_max, 0.05 * qa.coverage_max) << target;
  }
}

// Thousands of points at one spot (what many sensors write for missing returns) cost no more than
// one point there; the rest of the cloud is simplified as without them.
TEST(Filter, ManyPointsAtOneSpotAreOnePoint)
{
  auto sphere = fibonacciSphere(20000, 1.0, 0.0, 5);
  auto spiked = std::make_shared<Cloud>(*sphere);
  for (int i = 0; i < 20000; ++i)
    spiked->push_back(pcl::PointXYZ(0, 0, 0));
  Filter a, b;
  Cloud out_a, out_b;
  a.setInputCloud(sphere);
  a.filter(out_a);
  b.setInputCloud(spiked);
  b.filter(out_b);
  ASSERT_TRUE(b.getResult().error.empty()) << b.getResult().error;
  EXPECT_EQ(b.getResult().summary.merged_points, 19999u);
  // The one point at the centre is far from the sphere: a ball (or feature) of its own.
  EXPECT_LE(out_b.size(), out_a.size() + 3);
  EXPECT_GE(out_b.size(), out_a.size());
}

// The method is scale-free, and so is the filter at extreme scales: the bunny in units 1e-24 to
// 1e30 of its own is simplified as at unit scale (it hung, returned the input unchanged, or
// reported a zero error before), with lengths reported in the input's units.
TEST(Filter, ExtremeScalesGiveTheUnitScaleResult)
{
  const Cloud::Ptr bunny = loadShared("bunny.pcd");
  Filter unit;
  const Cloud out_unit = run(bunny, unit);
  const pcl_ecs::Summary ref = unit.getResult().summary;
  for (const double k : {1e-24, 1e-8, 1e8, 1e30})
  {
    Filter f;
    const Cloud out = run(scaledByDouble(*bunny, k), f);
    ASSERT_TRUE(f.getResult().error.empty()) << k << ": " << f.getResult().error;
    const pcl_ecs::Summary& s = f.getResult().summary;
    EXPECT_NEAR(static_cast<double>(out.size()), static_cast<double>(out_unit.size()), 0.01 * out_unit.size()) << k;
    EXPECT_NEAR(static_cast<double>(s.feature_points), static_cast<double>(ref.feature_points), 3.0) << k;
    EXPECT_NEAR(s.max_error, ref.max_error, 0.05 * ref.max_error) << k;
    EXPECT_NEAR(s.bbox_diagonal / k, ref.bbox_diagonal, 1e-5 * ref.bbox_diagonal) << k;
    EXPECT_NEAR(s.mean_spacing / k, ref.mean_spacing, 1e-3 * ref.mean_spacing) << k;
    EXPECT_NEAR(s.mean_abs_curvature * k, ref.mean_abs_curvature, 1e-3 * ref.mean_abs_curvature) << k;
    const auto& b = f.getResult().balls.front();
    EXPECT_LE(b.radius, 10.0 * s.neighborhood_radius) << k;
    EXPECT_LE((b.representative - b.centre).norm(), b.radius * (1 + 1e-6) + 1e-300) << k;
  }
  // An extent below what float can resolve is refused with a message.
  auto tiny = std::make_shared<Cloud>();
  for (int i = 0; i < 100; ++i)
    tiny->push_back(pcl::PointXYZ(1e-38f * static_cast<float>(i % 10), 1e-38f * static_cast<float>(i / 10), 0.0f));
  Filter t;
  Cloud out_t;
  t.setInputCloud(tiny);
  t.filter(out_t);
  EXPECT_TRUE(out_t.empty());
  EXPECT_NE(t.getResult().error.find("too small for float precision"), std::string::npos) << t.getResult().error;
}

TEST(Filter, MaxDeviationHoldsInTheInputsUnitsAtEveryScale)
{
  // The bunny at its own scale and at 1e8 × (a local frame scaled by a power of four): the bound
  // in input units, or as a fraction of L, holds and is reported in input units; without a bound
  // nothing is measured unless asked for.
  const Cloud::Ptr bunny = loadShared("bunny.pcd");
  Filter plain;
  Cloud out_plain = run(bunny, plain);
  EXPECT_FALSE(plain.getResult().summary.deviation_measured);
  plain.setReportDeviation(true);
  out_plain = run(bunny, plain);
  const pcl_ecs::Summary& ref = plain.getResult().summary;
  ASSERT_TRUE(ref.deviation_measured);
  EXPECT_EQ(ref.deviation_points, 0u);
  EXPECT_GE(ref.deviation_max, ref.deviation_p99);
  EXPECT_GE(ref.deviation_p99, 0.0);
  const double bound = 0.4 * ref.deviation_max;
  for (const double k : {1.0, 1e8})
  {
    const Cloud::Ptr scaled = scaledByDouble(*bunny, k);
    Filter f;
    f.setMaxDeviation(bound * k);
    const Cloud out = run(scaled, f);
    ASSERT_TRUE(f.getResult().error.empty()) << f.getResult().error;
    const pcl_ecs::Summary& s = f.getResult().summary;
    EXPECT_TRUE(s.deviation_measured);
    EXPECT_NEAR(s.max_deviation, bound * k, 1e-9 * bound * k) << k;
    EXPECT_LE(s.deviation_max, bound * k) << k;
    EXPECT_GT(s.deviation_points, 0u) << k;
    EXPECT_EQ(out.size(), s.output_points);
    EXPECT_GT(out.size(), out_plain.size());
    // The same bound as a fraction of L.
    Filter g;
    g.setMaxDeviationOfDiagonal(bound * k / s.bbox_diagonal);
    run(scaled, g);
    EXPECT_NEAR(g.getResult().summary.max_deviation, bound * k, 1e-6 * bound * k) << k;
    EXPECT_LE(g.getResult().summary.deviation_max, g.getResult().summary.max_deviation) << k;
  }
}

TEST(Filter, TErrInInputUnitsIsTheFractionOfTheDiagonal)
{
  // --terr-abs D is --terr D / L: the same output, point for point, at the bunny's scale and at
  // 1e8 × (a scaled local frame); a D not below L is refused with a message.
  const Cloud::Ptr bunny = loadShared("bunny.pcd");
  for (const double k : {1.0, 1e8})
  {
    const Cloud::Ptr scaled = scaledByDouble(*bunny, k);
    Filter rel;
    rel.setErrorThreshold(2e-3);
    const Cloud a = run(scaled, rel);
    const double L = rel.getResult().summary.bbox_diagonal;
    pcl_ecs::Parameters p;
    p.error_threshold_abs = 2e-3 * L;
    Filter abs;
    abs.setParameters(p);
    const Cloud b = run(scaled, abs);
    ASSERT_TRUE(abs.getResult().error.empty()) << abs.getResult().error;
    EXPECT_NEAR(abs.getResult().summary.error_threshold, 2e-3, 1e-15) << k;
    ASSERT_EQ(a.size(), b.size()) << k;
    for (std::size_t i = 0; i < a.size(); ++i)
      EXPECT_EQ(a[i].getVector3fMap(), b[i].getVector3fMap()) << k << " " << i;
    p.error_threshold_abs = 1.5 * L;
    Filter too_big;
    too_big.setParameters(p);
    EXPECT_TRUE(run(scaled, too_big).empty());
    EXPECT_NE(too_big.getResult().error.find("T_err must be below 1"), std::string::npos) << too_big.getResult().error;
  }
}

// A target-size search that lands at most 2% short tops the cover up (fillToCount): the output
// then holds exactly the target, the added points are counted, and the result does not depend on
// the thread count. Over a range of sizes on the bunny some runs land there and every run ends
// within 1%. With the relaxation (on by default) the cover the search settled on is relaxed and
// topped up by what its gap points fell short: more than 2%, but exactly the target again.
TEST(Filter, TargetSizeToppedUpToExactlyTheTarget)
{
  auto cloud = loadShared("bunny.pcd");
  for (const bool relax : {false, true})
  {
  SCOPED_TRACE(relax ? "relaxed" : "not relaxed");
  std::size_t topped_runs = 0;
  for (std::size_t target = 300; target <= 3000; target += 300)
  {
    Filter f;
    f.setTargetSize(target);
    f.setRelaxRepresentatives(relax);
    const Cloud out = run(cloud, f);
    const auto& s = f.getResult().summary;
    EXPECT_NEAR(static_cast<double>(out.size()), static_cast<double>(target), 0.01 * target) << target;
    EXPECT_TRUE(s.target_reached) << target;
    EXPECT_EQ(s.output_points, out.size());
    if (s.size_points == 0)
      continue;
    ++topped_runs;
    EXPECT_EQ(out.size(), target) << "topped up, yet not exactly the target";
    if (!relax)
      EXPECT_LE(static_cast<double>(s.size_points), 0.02 * static_cast<double>(target));
    Filter g;
    g.setTargetSize(target);
    g.setRelaxRepresentatives(relax);
    g.setNumberOfThreads(1);
    const Cloud one = run(cloud, g);
    ASSERT_EQ(one.size(), out.size());
    for (std::size_t i = 0; i < out.size(); ++i)
      ASSERT_EQ(one[i].getVector3fMap(), out[i].getVector3fMap()) << target << " point " << i;
  }
  EXPECT_GT(topped_runs, 0u) << "no size exercised the top-up";
  }
}

// A target of at least the input's distinct points keeps every point as it is, at once: the output
// holds the input's points, each once, and no more (a search topped its cover up with points
// beside output points: twice the input without the representative fit); the result says the
// target was not reached when it asked for more than 1% beyond them.
TEST(Filter, TargetAtOrAboveTheInputSizeKeepsEveryPoint)
{
  auto once = fibonacciSphere(5000, 1.0, 0.002, 3);
  auto twice = std::make_shared<Cloud>(*once);
  *twice += *once;  // 5,000 distinct points
  std::set<std::array<float, 3>> input;
  for (const auto& p : *once)
    input.insert({p.x, p.y, p.z});
  for (const bool fit : {true, false})
    for (const std::size_t target : {std::size_t{5000}, std::size_t{5040}, std::size_t{20000}})
    {
      SCOPED_TRACE(std::to_string(target) + (fit ? " fitted" : " not fitted"));
      Filter f;
      f.setTargetSize(target);
      f.setRepresentativeFit(fit);
      const Cloud out = run(twice, f);
      const auto& s = f.getResult().summary;
      ASSERT_EQ(out.size(), once->size());
      std::set<std::array<float, 3>> output;
      for (const auto& p : out)
        output.insert({p.x, p.y, p.z});
      EXPECT_EQ(output, input);
      EXPECT_EQ(s.output_points, out.size());
      EXPECT_EQ(s.cover_passes, 0);
      EXPECT_EQ(s.target_reached, target <= 5050);
    }
}

// No two output points coincide on the real scans whose unfitted balls gave way to one point
// several times (120 coincident output points on the kinect capture at 10% before), in memory and
// at a target size.
TEST(Filter, NoTwoOutputPointsCoincideOnARealScan)
{
  auto cloud = loadShared("kinect_capture0001.pcd");
  for (const std::size_t target : {std::size_t{0}, std::size_t{25000}})
  {
    SCOPED_TRACE(target);
    Filter f;
    f.setTargetSize(target);
    const Cloud out = run(cloud, f);
    ASSERT_TRUE(f.getResult().error.empty()) << f.getResult().error;
    std::set<std::array<float, 3>> at;
    for (const auto& p : out)
      at.insert({p.x, p.y, p.z});
    EXPECT_EQ(at.size(), out.size());
  }
}
