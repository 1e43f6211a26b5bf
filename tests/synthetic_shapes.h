// synthetic_shapes.h — seeded samplers of analytic shapes with exactly known geometry, shared by
// every test (and tested themselves in test_synthetic_shapes.cpp). Random numbers come from
// std::mt19937_64 (fully specified by the standard) through our own conversions, so a shape is
// the same on every platform.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace pcl_ecs_test
{

/** Uniform doubles in [0, 1) and standard normals, platform-independent. */
class Rng
{
public:
  explicit Rng(std::uint64_t seed) : engine_(seed) {}
  double uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double uniform(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  double normal()
  {
    // Box-Muller; uniform() < 1 so 1 - u > 0.
    const double u1 = 1.0 - uniform(), u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }

private:
  std::mt19937_64 engine_;
};

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

inline pcl::PointXYZ toPoint(const Eigen::Vector3d& p)
{
  return pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
}

/** A square grid of n × n points with spacing h on the plane z = 0, centred at the origin. */
inline Cloud::Ptr gridPlane(int n, double h)
{
  auto c = std::make_shared<Cloud>();
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      c->push_back(toPoint({(i - 0.5 * (n - 1)) * h, (j - 0.5 * (n - 1)) * h, 0.0}));
  return c;
}

/** n points uniform on the square [-s/2, s/2]² of the plane z = 0. */
inline Cloud::Ptr randomPlane(int n, double s, std::uint64_t seed)
{
  Rng rng(seed);
  auto c = std::make_shared<Cloud>();
  for (int i = 0; i < n; ++i)
    c->push_back(toPoint({rng.uniform(-0.5 * s, 0.5 * s), rng.uniform(-0.5 * s, 0.5 * s), 0.0}));
  return c;
}

/** n points uniform on [-0.5, 0.5]² in x, y; z Gaussian of deviation `smooth_noise` where x < 0 and
 * uniform in [-rough_depth, rough_depth] where x >= 0 (a layer of scattered returns, like
 * vegetation over ground). */
inline Cloud::Ptr halfRoughPlane(int n, double smooth_noise, double rough_depth, std::uint64_t seed)
{
  Rng rng(seed);
  auto c = std::make_shared<Cloud>();
  for (int i = 0; i < n; ++i)
  {
    const double x = rng.uniform(-0.5, 0.5), y = rng.uniform(-0.5, 0.5);
    const double z = x < 0.0 ? smooth_noise * rng.normal() : rng.uniform(-rough_depth, rough_depth);
    c->push_back(toPoint({x, y, z}));
  }
  return c;
}

/** n points on the sphere of radius rho centred at `centre`, on a Fibonacci spiral (nearly
 * uniform), each moved along the radius by Gaussian noise of standard deviation `noise`. */
inline Cloud::Ptr fibonacciSphere(int n, double rho, double noise = 0.0, std::uint64_t seed = 1,
                                  const Eigen::Vector3d& centre = Eigen::Vector3d::Zero())
{
  Rng rng(seed);
  auto c = std::make_shared<Cloud>();
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i)
  {
    const double z = 1.0 - 2.0 * (i + 0.5) / n;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden * i;
    const Eigen::Vector3d dir(r * std::cos(phi), r * std::sin(phi), z);
    const double radius = rho + (noise > 0.0 ? noise * rng.normal() : 0.0);
    c->push_back(toPoint(centre + radius * dir));
  }
  return c;
}

/** The surface of the axis-aligned cube [-a/2, a/2]³ sampled on a grid of m × m points per face
 * (spacing a / (m - 1); edge points shared by faces are emitted once), plus Gaussian noise of
 * standard deviation `noise` along the face normal. */
inline Cloud::Ptr cubeSurface(int m, double a, double noise = 0.0, std::uint64_t seed = 1)
{
  Rng rng(seed);
  auto c = std::make_shared<Cloud>();
  const double h = a / (m - 1);
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j)
      for (int k = 0; k < m; ++k)
      {
        const bool on_x = i == 0 || i == m - 1, on_y = j == 0 || j == m - 1, on_z = k == 0 || k == m - 1;
        if (!on_x && !on_y && !on_z)
          continue;
        Eigen::Vector3d p(-0.5 * a + i * h, -0.5 * a + j * h, -0.5 * a + k * h);
        if (noise > 0.0 && (on_x + on_y + on_z) == 1)  // noise only off the edges' exact lines
        {
          const int axis = on_x ? 0 : (on_y ? 1 : 2);
          p(axis) += noise * rng.normal();
        }
        c->push_back(toPoint(p));
      }
  return c;
}

/** Distance from p to the nearest edge of the cube [-a/2, a/2]³ (p near its surface). */
inline double distanceToCubeEdge(const Eigen::Vector3d& p, double a)
{
  // On a face, the nearest edge is at the smaller of the two in-face distances to the border.
  const Eigen::Vector3d d = (0.5 * a - p.cwiseAbs().array()).matrix();  // distance to each face
  // The coordinate with the smallest d is the face the point is on; the edge distance is the
  // second smallest of the three.
  double v[3] = {d.x(), d.y(), d.z()};
  std::sort(v, v + 3);
  return v[1];
}

/** n points uniform in (u, v) on the torus with radii R (tube centre) and r (tube). */
inline Cloud::Ptr torus(int nu, int nv, double R, double r)
{
  auto c = std::make_shared<Cloud>();
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j)
    {
      const double u = 2.0 * M_PI * i / nu, v = 2.0 * M_PI * j / nv;
      c->push_back(toPoint({(R + r * std::cos(v)) * std::cos(u), (R + r * std::cos(v)) * std::sin(u),
                            r * std::sin(v)}));
    }
  return c;
}

/** Directory of the shared scans (../shared/data beside the repository). */
inline std::string sharedData(const std::string& file)
{
  return std::string(PCL_ECS_SHARED_DATA_DIR) + "/" + file;
}

}  // namespace pcl_ecs_test
