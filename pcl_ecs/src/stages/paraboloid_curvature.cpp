#include <pcl_ecs/stages/paraboloid_curvature.h>

#include <pcl_ecs/stages/local_density.h>
#include <pcl_ecs/stages/tangent_frame.h>

#include "../detail/simd.h"

#include <algorithm>
#include <cmath>
#include <cstring>
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

/// Rows of a neighbourhood that the batched fit takes (K up to this; larger K fit one by one).
constexpr int kBatchRows = 64;

/// Lanes per batch of the fit, and their vector (GCC's vector extension: four doubles, two SSE2
/// registers in the portable build, one AVX2 register in the other).
constexpr int kLanes4 = 4;
typedef double Lanes4 __attribute__((vector_size(4 * sizeof(double))));
typedef long long Mask4 __attribute__((vector_size(4 * sizeof(long long))));

// (Vectors pass by reference: a 32-byte vector returned by value would change the ABI of the SSE2 build.)
PCL_ECS_ALWAYS_INLINE void load4(Lanes4& v, const double* a)
{
  std::memcpy(&v, a, sizeof v);
}

PCL_ECS_ALWAYS_INLINE void store4(double* a, Lanes4 v)
{
  std::memcpy(a, &v, sizeof v);
}

/// The row sums of tiltedFitLanes (AᵀA and Aᵀz, rows x², xy, y², x, y | z) for four lanes as
/// vectors; a row at the centre itself (x = y = 0) adds nothing and is not counted. Written with
/// vectors because GCC turns the selects of unrolled lanes into branches and runs them one by one.
PCL_ECS_ALWAYS_INLINE void rowSumsLanes4(int rows, const double (*centre)[kLanes4], const double (*normal)[kLanes4],
                                         const double (*p)[3][kLanes4], const double* inv_scale,
                                         const double (*u)[kLanes4], const double (*v)[kLanes4],
                                         double (*m)[kLanes4], double (*r)[kLanes4], int* used)
{
  Lanes4 c[3], n[3], fu[3], fv[3], is;  // the centres, normals and frames by coordinate
  for (int a = 0; a < 3; ++a)
  {
    load4(c[a], centre[a]);
    load4(n[a], normal[a]);
    load4(fu[a], u[a]);
    load4(fv[a], v[a]);
  }
  load4(is, inv_scale);
  const Lanes4 zero = {0.0, 0.0, 0.0, 0.0};
  Lanes4 mm[15], rr[5];
  for (Lanes4& e : mm)
    e = zero;
  for (Lanes4& e : rr)
    e = zero;
  Mask4 count = {0, 0, 0, 0};
  for (int k = 0; k < rows; ++k)
  {
    Lanes4 p0, p1, p2;
    load4(p0, p[k][0]);
    load4(p1, p[k][1]);
    load4(p2, p[k][2]);
    const Lanes4 q0 = (p0 - c[0]) * is;
    const Lanes4 q1 = (p1 - c[1]) * is;
    const Lanes4 q2 = (p2 - c[2]) * is;
    Lanes4 x = q0 * fu[0] + q1 * fu[1] + q2 * fu[2];
    Lanes4 y = q0 * fv[0] + q1 * fv[1] + q2 * fv[2];
    const Lanes4 zz = q0 * n[0] + q1 * n[1] + q2 * n[2];
    const Mask4 keep = x * x + y * y > zero;  // all ones where kept
    x = keep ? x : zero;
    y = keep ? y : zero;
    const Lanes4 z = keep ? zz : zero;
    count -= keep;
    const Lanes4 a[5] = {x * x, x * y, y * y, x, y};
    int e = 0;
    for (int i = 0; i < 5; ++i)
    {
      for (int j = 0; j <= i; ++j, ++e)
        mm[e] += a[i] * a[j];
      rr[i] += a[i] * z;
    }
  }
  for (int e = 0; e < 15; ++e)
    store4(m[e], mm[e]);
  for (int e = 0; e < 5; ++e)
    store4(r[e], rr[e]);
  for (int l = 0; l < kLanes4; ++l)
    used[l] = static_cast<int>(count[l]);
}

PCL_ECS_ALWAYS_INLINE void sqrt4(Lanes4& out, const Lanes4& v)
{
  for (int l = 0; l < kLanes4; ++l)
    out[l] = std::sqrt(v[l]);
}

/// The Cholesky solve and H of tiltedFitLanes for four lanes as vectors (each pivot at least
/// 1e-10 of the lane's largest diagonal entry, as normalEquations; a lane that fails is not solved).
PCL_ECS_ALWAYS_INLINE void solveLanes4(const double (*m)[kLanes4], const double (*r)[kLanes4], const int* used,
                                       const double* scale, double* h, bool* solved)
{
  const Lanes4 zero = {0.0, 0.0, 0.0, 0.0}, one = {1.0, 1.0, 1.0, 1.0};
  Lanes4 c[5][5], y[5], x[5];
  {
    int e = 0;
    for (int i = 0; i < 5; ++i)
      for (int j = 0; j <= i; ++j, ++e)
        load4(c[i][j], m[e]);
  }
  Lanes4 largest = zero, sc;
  for (int i = 0; i < 5; ++i)
    largest = largest < c[i][i] ? c[i][i] : largest;  // std::max(largest, c)
  load4(sc, scale);
  const Mask4 enough = {used[0] >= 5 ? -1 : 0, used[1] >= 5 ? -1 : 0, used[2] >= 5 ? -1 : 0,
                        used[3] >= 5 ? -1 : 0};
  Mask4 ok = (largest > zero) & enough & (sc > zero);
  for (int j = 0; j < 5; ++j)
  {
    Lanes4 d = c[j][j];
    for (int t = 0; t < j; ++t)
      d -= c[j][t] * c[j][t];
    ok &= d >= 1e-10 * largest;
    sqrt4(c[j][j], ok ? d : one);
    for (int i = j + 1; i < 5; ++i)
    {
      Lanes4 sum = c[i][j];
      for (int t = 0; t < j; ++t)
        sum -= c[i][t] * c[j][t];
      c[i][j] = sum / c[j][j];
    }
  }
  for (int i = 0; i < 5; ++i)
  {
    Lanes4 sum;
    load4(sum, r[i]);
    for (int t = 0; t < i; ++t)
      sum -= c[i][t] * y[t];
    y[i] = sum / c[i][i];
  }
  for (int i = 4; i >= 0; --i)
  {
    Lanes4 sum = y[i];
    for (int t = i + 1; t < 5; ++t)
      sum -= c[t][i] * x[t];
    x[i] = sum / c[i][i];
  }
  const Lanes4 d = x[3], ee = x[4];
  const Lanes4 g = 1.0 + d * d + ee * ee;
  Lanes4 root_g;
  sqrt4(root_g, g);
  const Lanes4 hv = ((1.0 + ee * ee) * x[0] - d * ee * x[1] + (1.0 + d * d) * x[2]) / (g * root_g * sc);
  store4(h, hv);
  for (int l = 0; l < kLanes4; ++l)
    solved[l] = ok[l] != 0;
}

/// The tilted fit (eq. 8-12 with the slope terms) of four neighbourhoods at once, lane l being one
/// point: the same operations for every lane (element-wise selects instead of branches), so a
/// lane's result does not depend on the others (a single point runs in all four). The row sums
/// and the solve are written with GCC's vector extension (rowSumsLanes4, solveLanes4), which left
/// to itself ran the unrolled lanes one by one. The normal equations are summed row after row
/// (each of their 20 sums one chain, in row order).
/// rows: the points per lane (<= kBatchRows); p[k][a][l]: coordinate a of lane l's k-th point.
/// Out: h[l] the mean curvature, solved[l] false when the normal equations are too ill-conditioned
/// for the lane (its h is then meaningless: the caller fits it by QR).
PCL_ECS_ALWAYS_INLINE void tiltedFitLanes(int rows, const double (*centre)[kLanes4],
                                          const double (*normal)[kLanes4], const double (*p)[3][kLanes4],
                                          double* h, bool* solved)
{
  // The local frame (u, v, n): u = n × (x or y axis, whichever is less parallel to n), normalised.
  double u[3][kLanes4], v[3][kLanes4];
  for (int l = 0; l < kLanes4; ++l)
  {
    const double n0 = normal[0][l], n1 = normal[1][l], n2 = normal[2][l];
    const bool use_x = std::abs(n0) < 0.9;
    const double u0 = use_x ? 0.0 : -n2, u1 = use_x ? n2 : 0.0, u2 = use_x ? -n1 : n0;
    const double len = std::sqrt(u0 * u0 + u1 * u1 + u2 * u2);
    u[0][l] = u0 / len;
    u[1][l] = u1 / len;
    u[2][l] = u2 / len;
    v[0][l] = n1 * u[2][l] - n2 * u[1][l];
    v[1][l] = n2 * u[0][l] - n0 * u[2][l];
    v[2][l] = n0 * u[1][l] - n1 * u[0][l];
  }
  // Coordinates scaled by the neighbourhood size (the largest distance from the centre).
  double inv_scale[kLanes4], scale[kLanes4];
  for (int l = 0; l < kLanes4; ++l)
    scale[l] = 0.0;
  for (int k = 0; k < rows; ++k)
    for (int l = 0; l < kLanes4; ++l)
    {
      const double q0 = p[k][0][l] - centre[0][l], q1 = p[k][1][l] - centre[1][l], q2 = p[k][2][l] - centre[2][l];
      scale[l] = std::max(scale[l], q0 * q0 + q1 * q1 + q2 * q2);
    }
  for (int l = 0; l < kLanes4; ++l)
  {
    scale[l] = std::sqrt(scale[l]);
    inv_scale[l] = scale[l] > 0.0 ? 1.0 / scale[l] : 0.0;
  }
  // AᵀA (lower triangle, row by row: m[0] = (0,0), m[1] = (1,0), m[2] = (1,1), ...) and Aᵀz over
  // the rows (x², xy, y², x, y | z); a row at the centre itself (x = y = 0) adds nothing and is
  // not counted.
  double m[15][kLanes4], r[5][kLanes4];
  int used[kLanes4];
  rowSumsLanes4(rows, centre, normal, p, inv_scale, u, v, m, r, used);
  // Cholesky AᵀA = L Lᵀ, each pivot at least 1e-10 of the largest diagonal entry (as
  // normalEquations), then L y = Aᵀz, Lᵀ x = y, and H of the fitted graph.
  solveLanes4(m, r, used, scale, h, solved);
}
}  // namespace

namespace
{
/// The fit from rows compacted one by one: the normal equations when `try_normal_equations` (the
/// path for more than kBatchRows points), else straight to the QR (a fit the lanes could not solve).
double fitByRows(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal,
                 const std::vector<Eigen::Vector3d>& points, ParaboloidFit fit, bool try_normal_equations)
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
  const bool solved = try_normal_equations &&
                      (cols == 3 ? normalEquations<3>(a, z, rows, coef) : normalEquations<5>(a, z, rows, coef));
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

/// Point i's table neighbours, in double, as the one-point fit takes them.
void gatherHood(const LocalCloud& cloud, const NeighborhoodTable& table, std::size_t i,
                std::vector<Eigen::Vector3d>& hood)
{
  const int* nb = table.neighbors(i);
  hood.resize(static_cast<std::size_t>(table.k));
  for (int k = 0; k < table.k; ++k)
    hood[static_cast<std::size_t>(k)] = cloud[nb[k]].getVector3fMap().cast<double>();
}

/// Lane l of a batch from the point's centre, normal and neighbours.
PCL_ECS_ALWAYS_INLINE void fillLane(int l, int rows, const pcl::PointXYZ& c, const Eigen::Vector3f& nrm,
                                    const int* nb, const LocalCloud& cloud, double (*centre)[4],
                                    double (*normal)[4], double (*p)[3][4])
{
  centre[0][l] = c.x;
  centre[1][l] = c.y;
  centre[2][l] = c.z;
  normal[0][l] = nrm.x();
  normal[1][l] = nrm.y();
  normal[2][l] = nrm.z();
  for (int k = 0; k < rows; ++k)
  {
    const pcl::PointXYZ& q = cloud[nb[k]];
    p[k][0][l] = q.x;
    p[k][1][l] = q.y;
    p[k][2][l] = q.z;
  }
}

/// Eq. 11 for the non-feature points of [begin, end), four at a time (the tilted fit, K <=
/// kBatchRows); a point whose normal equations are too ill-conditioned is fitted alone by QR.
PCL_ECS_ALWAYS_INLINE void curvatureRangeBody(const LocalCloud& cloud, const NormalList& normals,
                                              const NeighborhoodTable& table,
                                              const std::vector<std::uint8_t>& is_feature,
                                              std::ptrdiff_t begin, std::ptrdiff_t end,
                                              std::vector<double>& curvature)
{
  constexpr int W = kLanes4;
  const int rows = table.k;
  double centre[3][W], normal[3][W], p[kBatchRows][3][W], h[W];
  bool solved[W];
  std::size_t lane_point[W];
  int filled = 0;
  std::vector<Eigen::Vector3d> hood;
  for (std::ptrdiff_t ii = begin; ii < end || filled > 0; ++ii)
  {
    if (ii < end)
    {
      const auto i = static_cast<std::size_t>(ii);
      if (is_feature[i])
        continue;
      fillLane(filled, rows, cloud[i], normals[i], table.neighbors(i), cloud, centre, normal, p);
      lane_point[filled++] = i;
      if (filled < W)
        continue;
    }
    for (int l = filled; l < W; ++l)  // a last, partial batch: the spare lanes repeat lane 0
      fillLane(l, rows, cloud[lane_point[0]], normals[lane_point[0]], table.neighbors(lane_point[0]),
               cloud, centre, normal, p);
    tiltedFitLanes(rows, centre, normal, p, h, solved);
    for (int l = 0; l < filled; ++l)
    {
      const std::size_t i = lane_point[l];
      if (solved[l])
      {
        curvature[i] = h[l];
        continue;
      }
      gatherHood(cloud, table, i, hood);
      curvature[i] = fitByRows(cloud[static_cast<std::ptrdiff_t>(i)].getVector3fMap().cast<double>(),
                               normals[i].cast<double>(), hood, ParaboloidFit::Tilted, false);
    }
    filled = 0;
  }
}

void curvatureRangePortable(const LocalCloud& cloud, const NormalList& normals, const NeighborhoodTable& table,
                            const std::vector<std::uint8_t>& is_feature, std::ptrdiff_t begin,
                            std::ptrdiff_t end, std::vector<double>& curvature)
{
  curvatureRangeBody(cloud, normals, table, is_feature, begin, end, curvature);
}

#ifdef PCL_ECS_HAVE_AVX2_PATH
PCL_ECS_AVX2_TARGET void curvatureRangeAvx2(const LocalCloud& cloud, const NormalList& normals,
                                            const NeighborhoodTable& table,
                                            const std::vector<std::uint8_t>& is_feature,
                                            std::ptrdiff_t begin, std::ptrdiff_t end,
                                            std::vector<double>& curvature)
{
  curvatureRangeBody(cloud, normals, table, is_feature, begin, end, curvature);
}
#endif
}  // namespace

double paraboloidMeanCurvature(const Eigen::Vector3d& centre, const Eigen::Vector3d& normal,
                               const std::vector<Eigen::Vector3d>& points, ParaboloidFit fit)
{
  if (fit != ParaboloidFit::Tilted || points.size() > static_cast<std::size_t>(kBatchRows))
    return fitByRows(centre, normal, points, fit, true);
  // The batched fit with this point in all four lanes: the bits computeMeanCurvature gives it.
  const int rows = static_cast<int>(points.size());
  double c[3][kLanes4], n[3][kLanes4], p[kBatchRows][3][kLanes4];
  for (int l = 0; l < kLanes4; ++l)
    for (int a = 0; a < 3; ++a)
    {
      c[a][l] = centre(a);
      n[a][l] = normal(a);
      for (int k = 0; k < rows; ++k)
        p[k][a][l] = points[static_cast<std::size_t>(k)](a);
    }
  double h[kLanes4];
  bool solved[kLanes4];
  tiltedFitLanes(rows, c, n, p, h, solved);
  return solved[0] ? h[0] : fitByRows(centre, normal, points, fit, false);
}

void computeMeanCurvature(const LocalCloud& cloud, const NormalList& normals,
                          const NeighborhoodTable& table,
                          const std::vector<std::uint8_t>& is_feature, int threads,
                          std::vector<double>& curvature, ParaboloidFit fit)
{
  const std::ptrdiff_t n = static_cast<std::ptrdiff_t>(table.size());
  curvature.assign(static_cast<std::size_t>(n), 0.0);
  const bool batched = fit == ParaboloidFit::Tilted && table.k <= kBatchRows;
  const bool wide = detail::useAvx2();
  constexpr std::ptrdiff_t kChunk = 2048;
  const std::ptrdiff_t chunks = (n + kChunk - 1) / kChunk;
#pragma omp parallel num_threads(threads)
  {
    std::vector<Eigen::Vector3d> hood;  // one point's neighbours (gatherHood)
#pragma omp for schedule(dynamic, 1)
    for (std::ptrdiff_t chunk = 0; chunk < chunks; ++chunk)
    {
      const std::ptrdiff_t begin = chunk * kChunk, end = std::min(n, begin + kChunk);
      if (batched)
      {
#ifdef PCL_ECS_HAVE_AVX2_PATH
        if (wide)
        {
          curvatureRangeAvx2(cloud, normals, table, is_feature, begin, end, curvature);
          continue;
        }
#endif
        curvatureRangePortable(cloud, normals, table, is_feature, begin, end, curvature);
        continue;
      }
      for (std::ptrdiff_t i = begin; i < end; ++i)
      {
        if (is_feature[static_cast<std::size_t>(i)])
          continue;
        gatherHood(cloud, table, static_cast<std::size_t>(i), hood);
        curvature[static_cast<std::size_t>(i)] =
            paraboloidMeanCurvature(cloud[i].getVector3fMap().cast<double>(),
                                    normals[static_cast<std::size_t>(i)].cast<double>(), hood, fit);
      }
    }
  }
  (void)wide;
}

}  // namespace pcl_ecs
