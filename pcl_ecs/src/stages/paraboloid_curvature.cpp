#include <pcl_ecs/stages/paraboloid_curvature.h>
#include <pcl_ecs/stages/tangent_frame.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

#include <Eigen/Core>

namespace pcl_ecs
{

namespace
{
/// Σ a[i] b[i] over [from, to) with four partial sums: independent chains instead of one long
/// dependency chain of additions (the fit's reflections are dot products over the K rows).
inline double dotRange(const double* a, const double* b, int from, int to)
{
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
  int i = from;
  for (; i + 3 < to; i += 4)
  {
    s0 += a[i] * b[i];
    s1 += a[i + 1] * b[i + 1];
    s2 += a[i + 2] * b[i + 2];
    s3 += a[i + 3] * b[i + 3];
  }
  for (; i < to; ++i)
    s0 += a[i] * b[i];
  return (s0 + s1) + (s2 + s3);
}

/// Least squares min |A x - z| by Householder QR (eq. 9), on at most 5 columns stored column
/// by column. Small and allocation-free: the fit runs once per point. Returns false when a
/// column's R diagonal is negligible against the largest (the rows do not determine x).
bool householderLeastSquares(double (*a)[256], double* z, int rows, int cols, double* x)
{
  double diag[5];
  for (int j = 0; j < cols; ++j)
  {
    double* col = a[j];
    const double norm2 = dotRange(col, col, j, rows);
    const double norm = std::sqrt(norm2);
    if (!(norm > 0.0))
    {
      diag[j] = 0.0;
      continue;
    }
    const double alpha = col[j] > 0.0 ? -norm : norm;  // reflect away from the column
    // v = col[j..] - alpha e_j, stored in place; |v|² = 2 norm (norm + |col[j]|).
    const double vnorm2 = 2.0 * norm * (norm + std::abs(col[j]));
    col[j] -= alpha;
    auto reflect = [&](double* y) {
      const double s = dotRange(col, y, j, rows) * (2.0 / vnorm2);
      for (int i = j; i < rows; ++i)
        y[i] -= s * col[i];
    };
    for (int c = j + 1; c < cols; ++c)
      reflect(a[c]);
    reflect(z);
    diag[j] = alpha;
  }
  double largest = 0.0, smallest = std::numeric_limits<double>::infinity();
  for (int j = 0; j < cols; ++j)
  {
    largest = std::max(largest, std::abs(diag[j]));
    smallest = std::min(smallest, std::abs(diag[j]));
  }
  if (!(smallest > 1e-9 * largest))
    return false;
  // R x = (Q^T z)[0..cols): R's strict upper part sits in a[c][j] for c > j.
  for (int j = cols - 1; j >= 0; --j)
  {
    double s = z[j];
    for (int c = j + 1; c < cols; ++c)
      s -= a[c][j] * x[c];
    x[j] = s / diag[j];
  }
  return true;
}

/// Least squares min |A x - z| by the normal equations AᵀA x = Aᵀz and a Cholesky factorisation:
/// a third of the work of the QR. Returns false (and leaves the fit to the QR) unless every
/// pivot is at least 1e-10 of the largest diagonal entry of AᵀA, i.e. A's columns are far from
/// dependent (condition number below ~1e5): there the normal equations lose at most ~1e-6 of
/// the curvature's relative accuracy, and near-degenerate neighbourhoods get the QR's rank test.
template <int cols>
bool normalEquations(const double (*a)[256], const double* z, int rows, double* x)
{
  double m[5][5] = {}, r[5] = {};
  // Column by column: each entry is a dot product over contiguous rows (independent partial
  // sums, which the compiler pairs into vector lanes).
  for (int p = 0; p < cols; ++p)
  {
    r[p] = dotRange(a[p], z, 0, rows);
    for (int q = 0; q <= p; ++q)
      m[p][q] = dotRange(a[p], a[q], 0, rows);
  }
  double largest = 0.0;
  for (int p = 0; p < cols; ++p)
    largest = std::max(largest, m[p][p]);
  if (!(largest > 0.0))
    return false;
  // Cholesky m = L Lᵀ in place (lower triangle).
  for (int j = 0; j < cols; ++j)
  {
    double d = m[j][j];
    for (int k = 0; k < j; ++k)
      d -= m[j][k] * m[j][k];
    if (!(d >= 1e-10 * largest))
      return false;
    const double l = std::sqrt(d);
    m[j][j] = l;
    for (int i = j + 1; i < cols; ++i)
    {
      double s = m[i][j];
      for (int k = 0; k < j; ++k)
        s -= m[i][k] * m[j][k];
      m[i][j] = s / l;
    }
  }
  // L y = r, then Lᵀ x = y.
  for (int i = 0; i < cols; ++i)
  {
    double s = r[i];
    for (int k = 0; k < i; ++k)
      s -= m[i][k] * r[k];
    r[i] = s / m[i][i];
  }
  for (int i = cols - 1; i >= 0; --i)
  {
    double s = r[i];
    for (int k = i + 1; k < cols; ++k)
      s -= m[k][i] * x[k];
    x[i] = s / m[i][i];
  }
  return true;
}
}  // namespace

double paraboloidMeanCurvature(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal,
                               const std::vector<Eigen::Vector3d>& points, ParaboloidFit fit)
{
  Eigen::Vector3d u, v;
  tangentFrame(normal, u, v);
  const int cols = fit == ParaboloidFit::Literal ? 3 : 5;
  constexpr std::size_t kMaxRows = 256;  // K <= 200 in the method: the fit stays on the stack
  const std::size_t count = std::min(points.size(), kMaxRows);
  double scale = 0.0;
  for (std::size_t i = 0; i < count; ++i)
    scale = std::max(scale, (points[i] - centre).squaredNorm());
  scale = std::sqrt(scale);
  if (!(scale > 0.0))
    return 0.0;
  const double inv_scale = 1.0 / scale;
  double a[5][kMaxRows];  // eq. 8 (+ x, y for the tilted fit), column by column
  double z[kMaxRows];     // eq. 10
  int rows = 0;
  for (std::size_t i = 0; i < count; ++i)
  {
    // Coordinates scaled by the neighbourhood size so the rank decision of the QR is scale-free.
    const Eigen::Vector3d q = (points[i] - centre) * inv_scale;
    const double x = q.dot(u), y = q.dot(v);
    if (x * x + y * y <= 0.0)
      continue;  // the centre (or a duplicate) adds nothing to a fit through the origin
    a[0][rows] = x * x;
    a[1][rows] = x * y;
    a[2][rows] = y * y;
    a[3][rows] = x;
    a[4][rows] = y;
    z[rows] = q.dot(normal);
    ++rows;
  }
  if (rows < cols)
    return 0.0;
  double coef[5];
  // Eq. 9, well conditioned: the normal equations (the column count fixed at compile time, so the
  // small loops unroll); otherwise the QR, stable, with a rank test.
  const bool solved = cols == 3 ? normalEquations<3>(a, z, rows, coef) : normalEquations<5>(a, z, rows, coef);
  if (!solved &&
      !householderLeastSquares(a, z, rows, cols, coef))
    return 0.0;
  const double ca = coef[0], cb = coef[1], cc = coef[2];
  if (cols == 3)
    return (ca + cc) / scale;  // eq. 11
  // Mean curvature of the graph z = f(x, y) at the origin, with the fitted slope (d, e) of a
  // normal that is slightly off; equals a + c when d = e = 0.
  const double d = coef[3], e = coef[4];
  const double g = 1.0 + d * d + e * e;
  return ((1.0 + e * e) * ca - d * e * cb + (1.0 + d * d) * cc) / (g * std::sqrt(g) * scale);
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
