#include <pcl_ecs/stages/paraboloid_curvature.h>
#include <pcl_ecs/stages/tangent_frame.h>

#include <cmath>
#include <cstddef>

#include <Eigen/Dense>

namespace pcl_ecs
{

double paraboloidMeanCurvature(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal,
                               const std::vector<Eigen::Vector3d>& points, ParaboloidFit fit)
{
  Eigen::Vector3d u, v;
  tangentFrame(normal, u, v);
  const int cols = fit == ParaboloidFit::Literal ? 3 : 5;
  // Fixed maximum sizes keep the per-point fit off the heap (K <= 200, so at most 201 rows).
  using Rows = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 256, 5>;
  using Col = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 256, 1>;
  if (points.size() > 256)
    return paraboloidMeanCurvature(centre, normal,
                                   std::vector<Eigen::Vector3d>(points.begin(), points.begin() + 256), fit);
  Rows A(static_cast<Eigen::Index>(points.size()), cols);  // eq. 8 (+ x, y for the tilted fit)
  Col z(static_cast<Eigen::Index>(points.size()));         // eq. 10
  Eigen::Index rows = 0;
  double scale = 0.0;
  for (const auto& p : points)
    scale = std::max(scale, std::sqrt((p - centre).squaredNorm()));
  if (!(scale > 0.0))
    return 0.0;
  for (const auto& p : points)
  {
    // Coordinates scaled by the neighbourhood size so the rank decision of the QR is scale-free.
    const Eigen::Vector3d q = (p - centre) / scale;
    const double x = q.dot(u), y = q.dot(v);
    if (x * x + y * y <= 0.0)
      continue;  // the centre (or a duplicate) adds nothing to a fit through the origin
    if (cols == 3)
      A.row(rows) << x * x, x * y, y * y;
    else
      A.row(rows) << x * x, x * y, y * y, x, y;
    z(rows) = q.dot(normal);
    ++rows;
  }
  if (rows < cols)
    return 0.0;
  // Householder QR (eq. 9 "solved by Householder transformation"); a column whose R diagonal is
  // negligible means the neighbours do not determine the paraboloid.
  const Rows Ar = A.topRows(rows);
  Eigen::HouseholderQR<Rows> qr(Ar);
  const auto diag = qr.matrixQR().diagonal().cwiseAbs();
  if (!(diag.minCoeff() > 1e-9 * diag.maxCoeff()))
    return 0.0;
  const Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 5, 1> coef = qr.solve(Col(z.head(rows)));  // eq. 9
  const double a = coef(0), b = coef(1), c = coef(2);
  if (cols == 3)
    return (a + c) / scale;  // eq. 11
  // Mean curvature of the graph z = f(x, y) at the origin, with the fitted slope (d, e) of a
  // normal that is slightly off; equals a + c when d = e = 0.
  const double d = coef(3), e = coef(4);
  const double g = 1.0 + d * d + e * e;
  return ((1.0 + e * e) * a - d * e * b + (1.0 + d * d) * c) / (std::pow(g, 1.5) * scale);
}

void computeMeanCurvature(const LocalCloud& cloud, const NormalList& normals,
                          const NeighborhoodTable& table,
                          const std::vector<std::uint8_t>& is_feature, int threads,
                          std::vector<double>& curvature, ParaboloidFit fit)
{
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(table.size());
  curvature.assign(static_cast<std::size_t>(n), 0.0);
#pragma omp parallel num_threads(threads)
  {
    std::vector<Eigen::Vector3d> hood(static_cast<std::size_t>(table.k));
#pragma omp for schedule(dynamic, 2048)
    for (std::ptrdiff_t i = 0; i < n; ++i)
    {
      if (is_feature[static_cast<std::size_t>(i)])
        continue;
      const int* nb = table.neighbors(static_cast<std::size_t>(i));
      for (int j = 0; j < table.k; ++j)
        hood[static_cast<std::size_t>(j)] = cloud[nb[j]].getVector3fMap().cast<double>();
      curvature[static_cast<std::size_t>(i)] =
          paraboloidMeanCurvature(cloud[i].getVector3fMap().cast<double>(),
                                  normals[static_cast<std::size_t>(i)].cast<double>(), hood, fit);
    }
  }
}

double meanAbsCurvature(const std::vector<double>& curvature,
                        const std::vector<std::uint8_t>& is_feature)
{
  double sum = 0.0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < curvature.size(); ++i)
    if (!is_feature[i])
    {
      sum += std::abs(curvature[i]);
      ++count;
    }
  return count ? sum / static_cast<double>(count) : 0.0;
}

}  // namespace pcl_ecs
