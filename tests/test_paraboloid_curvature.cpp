#include <pcl_ecs/stages/paraboloid_curvature.h>
#include <pcl_ecs/stages/global_stats.h>
#include <pcl_ecs/stages/tangent_frame.h>

#include <Eigen/Dense>

#include "detail/simd.h"  // private: switch the AVX2 loops off and on
#include "synthetic_shapes.h"
#include "test_support.h"

#include <gtest/gtest.h>

#include <cstring>

using namespace pcl_ecs_test;

namespace
{
/// Eq. 12's mean |H| over the non-feature points, as the method takes it (GlobalStats).
double meanAbsH(const std::vector<double>& H, const std::vector<std::uint8_t>& feature)
{
  pcl_ecs::GlobalStats stats;
  stats.addNonFeatures(std::vector<double>(H.size(), 0.0), std::vector<double>(H.size(), 1.0), H, feature);
  return stats.meanAbsCurvature();
}
}  // namespace

// Points exactly on z = a x² + b xy + c y² in a tilted frame: the fit recovers H = a + c.
TEST(ParaboloidCurvature, ExactOnAParaboloid)
{
  const double a = 0.7, b = -0.3, c = 1.9;
  const Eigen::Vector3d normal = Eigen::Vector3d(1, 2, 3).normalized();
  const Eigen::Vector3d centre(5, -2, 1);
  Eigen::Vector3d u = normal.cross(Eigen::Vector3d::UnitX()).normalized();
  Eigen::Vector3d v = normal.cross(u);
  std::vector<Eigen::Vector3d> pts;
  Rng rng(11);
  for (int i = 0; i < 20; ++i)
  {
    const double x = rng.uniform(-0.1, 0.1), y = rng.uniform(-0.1, 0.1);
    pts.push_back(centre + x * u + y * v + (a * x * x + b * x * y + c * y * y) * normal);
  }
  EXPECT_NEAR(pcl_ecs::paraboloidMeanCurvature(centre, normal, pts), a + c, 1e-9);
  EXPECT_NEAR(pcl_ecs::paraboloidMeanCurvature(centre, normal, pts, pcl_ecs::ParaboloidFit::Literal),
              a + c, 1e-9);
  // The fit is in the frame of the normal, whatever its in-plane axes: flipping n flips H.
  EXPECT_NEAR(pcl_ecs::paraboloidMeanCurvature(centre, -normal, pts), -(a + c), 1e-9);
}

TEST(ParaboloidCurvature, UnderdeterminedFitGivesZero)
{
  const std::vector<Eigen::Vector3d> pts = {{0, 0, 0}, {1, 0, 0.1}};
  EXPECT_EQ(pcl_ecs::paraboloidMeanCurvature({0, 0, 0}, {0, 0, 1}, pts), 0.0);
}

TEST(ParaboloidCurvature, ZeroOnAPlane)
{
  auto cloud = randomPlane(2000, 1.0, 3);
  const auto table = makeTable(cloud, 16);
  const std::vector<std::uint8_t> none(cloud->size(), 0);
  std::vector<double> H;
  pcl_ecs::computeMeanCurvature(*cloud, makeNormals(cloud, table), table, none, 2, H);
  for (double h : H)
    EXPECT_LT(std::abs(h), 1e-6);
  EXPECT_LT(meanAbsH(H, none), 1e-6);
}

// Sphere of radius ρ = 2 sampled densely: |H| within 3% of 1/ρ at every point.
TEST(ParaboloidCurvature, SphereOfKnownRadius)
{
  const double rho = 2.0;
  auto cloud = fibonacciSphere(40000, rho);
  const auto table = makeTable(cloud, 16);
  const std::vector<std::uint8_t> none(cloud->size(), 0);
  std::vector<double> H;
  pcl_ecs::computeMeanCurvature(*cloud, makeNormals(cloud, table), table, none, 2, H);
  for (double h : H)
    EXPECT_NEAR(std::abs(h), 1.0 / rho, 0.03 / rho);
  EXPECT_NEAR(meanAbsH(H, none), 1.0 / rho, 0.01 / rho);
}

TEST(ParaboloidCurvature, FeaturePointsAreSkipped)
{
  auto cloud = fibonacciSphere(2000, 1.0);
  const auto table = makeTable(cloud, 16);
  std::vector<std::uint8_t> feature(cloud->size(), 0);
  feature[7] = 1;
  std::vector<double> H;
  pcl_ecs::computeMeanCurvature(*cloud, makeNormals(cloud, table), table, feature, 1, H);
  EXPECT_EQ(H[7], 0.0);
  EXPECT_GT(std::abs(H[8]), 0.9);
}

// Noisy neighbourhoods (no exact fit): the least-squares solution equals Eigen's reference solver
// on the same design matrix, for both fits.
TEST(ParaboloidCurvature, LeastSquaresMatchesAReferenceSolver)
{
  Rng rng(5);
  for (int trial = 0; trial < 200; ++trial)
  {
    const Eigen::Vector3d normal =
        Eigen::Vector3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.2, 1)).normalized();
    const Eigen::Vector3d centre(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5));
    Eigen::Vector3d u, v;
    pcl_ecs::tangentFrame(normal, u, v);
    std::vector<Eigen::Vector3d> pts;
    const int count = 8 + trial % 40;
    for (int i = 0; i < count; ++i)
    {
      const double x = rng.uniform(-0.3, 0.3), y = rng.uniform(-0.3, 0.3);
      pts.push_back(centre + x * u + y * v +
                    (0.4 * x * x - 0.2 * x * y + 1.1 * y * y + 0.05 * x + rng.uniform(-0.01, 0.01)) * normal);
    }
    for (const auto fit : {pcl_ecs::ParaboloidFit::Literal, pcl_ecs::ParaboloidFit::Tilted})
    {
      const int cols = fit == pcl_ecs::ParaboloidFit::Literal ? 3 : 5;
      double scale = 0.0;
      for (const auto& p : pts)
        scale = std::max(scale, (p - centre).norm());
      Eigen::MatrixXd A(count, cols);
      Eigen::VectorXd z(count);
      for (int i = 0; i < count; ++i)
      {
        const Eigen::Vector3d q = (pts[static_cast<std::size_t>(i)] - centre) / scale;
        const double x = q.dot(u), y = q.dot(v);
        Eigen::RowVectorXd row(5);
        row << x * x, x * y, y * y, x, y;
        A.row(i) = row.head(cols);
        z(i) = q.dot(normal);
      }
      const Eigen::VectorXd c = A.colPivHouseholderQr().solve(z);
      double expected = (c(0) + c(2)) / scale;
      if (cols == 5)
      {
        const double g = 1.0 + c(3) * c(3) + c(4) * c(4);
        expected = ((1.0 + c(4) * c(4)) * c(0) - c(3) * c(4) * c(1) + (1.0 + c(3) * c(3)) * c(2)) /
                   (std::pow(g, 1.5) * scale);
      }
      EXPECT_NEAR(pcl_ecs::paraboloidMeanCurvature(centre, normal, pts, fit), expected,
                  1e-9 * std::max(1.0, std::abs(expected)))
          << "trial " << trial << " cols " << cols;
    }
  }
}

// Neighbours along one line of the tangent plane: x², xy and y² are then proportional, the fit
// has no unique answer, and both solvers (the normal equations, then the QR) must see it.
TEST(ParaboloidCurvature, CollinearNeighboursGiveZero)
{
  const Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d u, v;
  pcl_ecs::tangentFrame(normal, u, v);
  std::vector<Eigen::Vector3d> pts;
  for (int i = -8; i <= 8; ++i)
  {
    const double x = 0.01 * i, y = 0.5 * x;
    pts.push_back(x * u + y * v + 3.0 * x * x * normal);
  }
  for (const auto fit : {pcl_ecs::ParaboloidFit::Literal, pcl_ecs::ParaboloidFit::Tilted})
    EXPECT_EQ(pcl_ecs::paraboloidMeanCurvature(Eigen::Vector3d::Zero(), normal, pts, fit), 0.0);
}

// computeMeanCurvature fits four points at a time (the lanes of one vector register where the CPU
// has AVX2): each point must get exactly the value of its own fit, with the AVX2 build of the
// lanes and without, in a partial last batch, next to feature points, and where the normal
// equations fail and the point is fitted by QR (neighbours on a line).
TEST(ParaboloidCurvature, BatchedFitsGiveEachPointTheBitsOfItsOwnFit)
{
  auto cloud = fibonacciSphere(2001, 1.5);
  for (int i = 0; i < 40; ++i)  // a line far from the sphere: collinear neighbourhoods
    cloud->push_back(toPoint({10.0 + 0.01 * i, 3.0, -2.0}));
  const auto table = makeTable(cloud, 16);
  const auto normals = makeNormals(cloud, table);
  std::vector<std::uint8_t> feature(cloud->size(), 0);
  for (std::size_t i = 3; i < cloud->size(); i += 97)
    feature[i] = 1;
  for (const bool avx2 : {false, true})
  {
    pcl_ecs::detail::allowAvx2(avx2);
    std::vector<double> H;
    pcl_ecs::computeMeanCurvature(*cloud, normals, table, feature, 2, H);
    pcl_ecs::detail::allowAvx2(true);
    std::size_t wrong = 0, zero_on_line = 0;
    for (std::size_t i = 0; i < cloud->size(); ++i)
    {
      if (feature[i])
      {
        wrong += H[i] != 0.0 ? 1 : 0;
        continue;
      }
      std::vector<Eigen::Vector3d> hood;
      for (int j = 0; j < table.k; ++j)
        hood.push_back((*cloud)[static_cast<std::size_t>(table.neighbors(i)[j])].getVector3fMap().cast<double>());
      const double own = pcl_ecs::paraboloidMeanCurvature((*cloud)[i].getVector3fMap().cast<double>(),
                                                          normals[i].cast<double>(), hood);
      wrong += std::memcmp(&own, &H[i], sizeof own) != 0 ? 1 : 0;
      zero_on_line += i >= 2001 && H[i] == 0.0 ? 1 : 0;
    }
    EXPECT_EQ(wrong, 0u) << "AVX2 " << (avx2 && pcl_ecs::detail::useAvx2());
    EXPECT_GT(zero_on_line, 30u);  // the QR sees the line's fits as underdetermined
  }
}
