#include <pcl_ecs/simplify_core.h>

#include <pcl_ecs/neighborhood.h>
#include <pcl_ecs/stages/density_weights.h>
#include <pcl_ecs/stages/feature_measure.h>
#include <pcl_ecs/stages/gap_fill.h>
#include <pcl_ecs/stages/local_density.h>
#include <pcl_ecs/stages/normals.h>
#include <pcl_ecs/stages/paraboloid_curvature.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <list>
#include <optional>
#include <sstream>
#include <utility>

#include <Eigen/Eigenvalues>
#include <pcl_ecs/search/box_tree_search.h>

namespace pcl_ecs
{

namespace
{
using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0)
{
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// True when the points lie on one line (or one point): no surface to simplify.
bool collinear(const LocalCloud& cloud)
{
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : cloud)
    mean += p.getVector3fMap().cast<double>();
  mean /= static_cast<double>(cloud.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : cloud)
  {
    const Eigen::Vector3d q = p.getVector3fMap().cast<double>() - mean;
    cov.noalias() += q * q.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov, Eigen::EigenvaluesOnly);
  const Eigen::Vector3d ev = es.eigenvalues();
  return !(ev(1) > 1e-12 * ev(2));
}

/// The cover at one T_err, then the gaps wider than `gap` closed; the output size is features + balls.
std::size_t runCover(const CoverInput& in, const Parameters& params, double terr, double gap, CoverOutput& out,
                     std::size_t& gap_points)
{
  coverWithBalls(in, params, terr, out);
  gap_points = fillGaps(in, params, terr, gap, out);
  return out.balls.size();
}
}  // namespace

double boundingBoxDiagonal(const LocalCloud& cloud)
{
  if (cloud.empty())
    return 0.0;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const auto& p : cloud)
  {
    const Eigen::Vector3d q = p.getVector3fMap().cast<double>();
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  return (hi - lo).norm();
}

Status simplifyLocal(const LocalCloud::ConstPtr& cloud_ptr, const NormalList* input_normals,
                     const Parameters& params, const ProgressCallback& progress, CoreOutput& out)
{
  out = CoreOutput{};
  const LocalCloud& cloud = *cloud_ptr;
  const int threads = resolveThreads(params.threads);
  const int k = params.k_neighbors;
  auto report = [&](const char* stage, double f) {
    if (progress)
      progress(stage, f);
  };
  Summary& s = out.summary;
  s.finite_points = cloud.size();

  if (cloud.size() <= static_cast<std::size_t>(k))
  {
    std::ostringstream os;
    os << "only " << cloud.size() << (cloud.size() == 1 ? " finite point" : " finite points")
       << "; the neighbourhood size K = " << k
       << " needs at least " << k + 1;
    out.error = os.str();
    return Status::TooFewPoints;
  }
  s.bbox_diagonal = boundingBoxDiagonal(cloud);
  if (!(s.bbox_diagonal > 0.0) || collinear(cloud))
  {
    out.error = s.bbox_diagonal > 0.0 ? "all points lie on one line: there is no surface to simplify"
                                      : "all points are identical: there is no surface to simplify";
    return Status::Degenerate;
  }
  if (input_normals && input_normals->size() != cloud.size())
  {
    out.error = "the input normals do not match the points";
    return Status::InvalidArgument;
  }

  // The one K-neighbourhood query (eq. 1, 2, 3, 7-12 all read it).
  auto t = Clock::now();
  report("neighbours", 0.0);
  BoxTreeSearch tree(/*sorted=*/false, threads);  // unsorted radius results; the points come in Hilbert order
  tree.setInputCloud(cloud_ptr);
  NeighborhoodTable table;
  computeNeighborhoods(cloud, tree, k, threads, table);
  s.timings.neighbors = secondsSince(t);

  t = Clock::now();
  report("normals", 0.0);
  if (input_normals)
  {
    out.normals = *input_normals;
    std::size_t bad = 0;
    if (normalizeInputNormals(out.normals, bad) != Status::Ok)
    {
      std::ostringstream os;
      os << "input normal of point " << bad << " is not finite or has zero length";
      out.error = os.str();
      return Status::BadNormals;
    }
  }
  else
  {
    estimateNormals(cloud, table, threads, out.normals);
  }
  s.timings.normals = secondsSince(t);

  t = Clock::now();
  computeDensityWeights(cloud, table, out.weights, threads);
  s.timings.weights = secondsSince(t);

  t = Clock::now();
  report("features", 0.0);
  computeFeatureMeasure(cloud, out.normals, table, threads, out.measure);
  s.feature_threshold = featureThreshold(out.measure, params.feature_factor);
  s.feature_points = classifyFeatures(out.measure, s.feature_threshold, out.is_feature);
  s.timings.features = secondsSince(t);

  if (s.feature_points == cloud.size())
  {
    // Every point is a feature point (possible only for α < 1): nothing to cover.
    s.output_points = s.feature_points;
    return Status::Ok;
  }

  t = Clock::now();
  report("density", 0.0);
  computeLocalDensity(cloud, table, out.is_feature, tree, threads, out.density);
  s.mean_spacing = meanOverNonFeatures(out.density, out.is_feature);
  s.neighborhood_radius =
      meanOverNonFeaturesOf(out.is_feature, [&](std::size_t i) { return std::sqrt(out.weights[i]); });
  s.timings.density = secondsSince(t);

  t = Clock::now();
  report("curvature", 0.0);
  computeMeanCurvature(cloud, out.normals, table, out.is_feature, threads, out.curvature);
  table = NeighborhoodTable{};  // the cover does not read it: 4 K bytes a point less at its peak
  s.mean_abs_curvature = meanAbsCurvature(out.curvature, out.is_feature);
  s.timings.curvature = secondsSince(t);

  t = Clock::now();
  report("cover", 0.0);
  const CoverInput in{cloud,         out.normals,          out.weights,    out.is_feature,
                      out.curvature, out.density,          s.mean_abs_curvature,
                      s.mean_spacing, s.neighborhood_radius, s.bbox_diagonal, tree};
  if (params.target_size == 0)
  {
    s.error_threshold = params.error_threshold;
    s.radius_cap_factor = params.radius_cap_factor;
    s.max_gap = params.max_gap_factor * params.radius_cap_factor * s.neighborhood_radius;
    runCover(in, params, s.error_threshold, s.max_gap, out.cover, s.gap_points);
    s.target_iterations = 1;
    s.cover_passes = 1;
  }
  else
  {
    // Search T_err (log scale) for |features + balls - target| <= 1% of target, or the closest.
    const double target = static_cast<double>(params.target_size);
    const double balls_wanted = target - static_cast<double>(s.feature_points);
    // The radius cap follows the target (Parameters::target_radius_cap).
    Parameters cover_params = params;
    if (params.target_radius_cap > 0.0 && balls_wanted >= 1.0)
    {
      const double nonfeature = static_cast<double>(cloud.size() - s.feature_points);
      const double implied = std::sqrt(nonfeature / (static_cast<double>(params.k_neighbors) * balls_wanted));
      cover_params.radius_cap_factor = std::min(1000.0, std::max(1e-3, params.target_radius_cap * implied));
    }
    s.radius_cap_factor = cover_params.radius_cap_factor;
    // The gap bound, in neighbourhood radii: target_gap_factor × the cap the target implies.
    const double gap_ratio = params.target_radius_cap > 0.0 ? params.target_gap_factor : params.max_gap_factor;
    double gap_factor = gap_ratio * cover_params.radius_cap_factor;
    auto distance = [&](std::size_t balls) {
      return std::abs(static_cast<double>(s.feature_points + balls) - target);
    };
    double best_distance = std::numeric_limits<double>::infinity();
    CoverOutput trial;
    // The fewest balls the current search reached, and how many of them closed gaps.
    std::size_t fewest = std::numeric_limits<std::size_t>::max(), fewest_gaps = 0;
    // The last few covers before their gap points, with their T and cap: a search that only
    // widens the gap bound, or comes back to a T it tried at this cap, reuses the cover and redoes
    // only the gap bound (the same result as running it again).
    struct CachedCover
    {
      double terr, cap;
      CoverOutput cover;
    };
    std::list<CachedCover> covers;  // most recent first
    constexpr std::size_t kCachedCovers = 3;
    // Balls of the last cover below the radius cap: when they are fewer than the tolerance, a
    // larger T cannot remove enough balls (every other ball is at the cap already).
    std::size_t below_cap = 0;
    // The count at saturation in the current search (cap and gap bound): the fewest balls of a
    // cover whose balls are nearly all at the cap.
    double floor_count = std::numeric_limits<double>::infinity();
    auto attempt = [&](double terr) {
      std::size_t gaps = 0;
      auto hit = std::find_if(covers.begin(), covers.end(), [&](const CachedCover& c) {
        return c.terr == terr && c.cap == cover_params.radius_cap_factor;
      });
      if (hit == covers.end())
      {
        if (covers.size() >= kCachedCovers)
          covers.pop_back();
        covers.push_front({terr, cover_params.radius_cap_factor, CoverOutput{}});
        coverWithBalls(in, cover_params, terr, covers.front().cover);
        ++s.cover_passes;
      }
      else
        covers.splice(covers.begin(), covers, hit);
      const CoverOutput& cached = covers.front().cover;
      const double cap = cover_params.radius_cap_factor * s.neighborhood_radius;
      below_cap = 0;
      for (const CoverBall& b : cached.balls)
        below_cap += b.radius < cap * (1.0 - 1e-9) ? 1 : 0;
      trial = cached;
      gaps = fillGaps(in, cover_params, terr, gap_factor * s.neighborhood_radius, trial);
      const std::size_t balls = trial.balls.size();
      ++s.target_iterations;
      // Nearly saturated (at most 5% of the balls, or the tolerance, below the cap): about the
      // count the cap sets.
      if (static_cast<double>(below_cap) < std::max(0.01 * target, 0.05 * static_cast<double>(balls)))
        floor_count = std::min(floor_count, static_cast<double>(balls));
      if (balls < fewest)
      {
        fewest = balls;
        fewest_gaps = gaps;
      }
      report("cover", std::min(1.0, s.target_iterations / 40.0));
      if (distance(balls) < best_distance)
      {
        best_distance = distance(balls);
        s.error_threshold = terr;
        s.gap_points = gaps;
        s.max_gap = gap_factor * s.neighborhood_radius;
        std::swap(out.cover, trial);
      }
      return static_cast<double>(balls);
    };
    const double lowest = 1e-12, highest = 0.999;
    // Where a search found the count saturated (the same at T and 4 T: every ball at the cap), per
    // cap: a later search at that cap (a wider gap bound) that starts at or above that T with too
    // many balls is saturated too, and need not probe 4 T again.
    double saturated_cap = -1.0, saturated_terr = highest;
    const double tol = 0.01 * target;
    // One search at the current cap and gap bound: bracket T, then solve inside the bracket. A
    // count that changes by less than the tolerance while T moves by 4×, or a cover whose balls are
    // all at the cap, means the radius cap (or the point count), not T, sets it: this cap cannot
    // do better.
    auto search = [&]() {
      const double before = best_distance;
      floor_count = std::numeric_limits<double>::infinity();
      fewest = std::numeric_limits<std::size_t>::max();
      // The first search starts at the user's T_err, a later one (wider gap or cap) at the best so far.
      const double start = std::isfinite(best_distance) ? s.error_threshold : params.error_threshold;
      double lo = std::min(std::max(start, lowest), highest);  // T giving too many
      double hi = lo;                                                           // T giving too few
      double b_lo = attempt(lo), b_hi = b_lo;
      if (std::abs(b_lo - balls_wanted) <= tol)
        return best_distance < before;
      if (b_lo > balls_wanted && cover_params.radius_cap_factor == saturated_cap && lo >= saturated_terr)
        return best_distance < before;
      if (b_lo > balls_wanted && static_cast<double>(below_cap) < tol)
      {
        // Saturated already: nearly every ball is at the cap, so a larger T changes nothing.
        saturated_cap = cover_params.radius_cap_factor;
        saturated_terr = lo;
        return best_distance < before;
      }
      if (b_lo > balls_wanted)
      {
        while (b_hi > balls_wanted && hi < highest && best_distance > tol)
        {
          lo = hi;
          b_lo = b_hi;
          hi = std::min(hi * 4.0, highest);
          b_hi = attempt(hi);
          // Saturated: the balls below the cap are too few to matter, or T × 4 removed fewer
          // balls than the tolerance (every ball near the cap).
          if (b_hi > balls_wanted && (static_cast<double>(below_cap) < tol || b_hi > b_lo - tol))
          {
            saturated_cap = cover_params.radius_cap_factor;
            saturated_terr = static_cast<double>(below_cap) < tol ? hi : lo;
            return best_distance < before;
          }
        }
        if (b_hi > balls_wanted)
          return best_distance < before;
      }
      else
      {
        // Too few balls. Down by ×4 while the cover is saturated (every ball at the cap: the count
        // stays put until T is small enough to shrink balls); then, from two trials, by the step
        // their power law gives to the wanted count, passed by 30% to bracket it (1.5 to 16).
        double t_prev = hi, b_prev = b_hi;
        bool saturated = static_cast<double>(below_cap) < tol;
        while (b_lo < balls_wanted && lo > lowest && best_distance > tol)
        {
          double factor = 4.0;
          const double p = t_prev != lo && b_prev > 0.0 && b_lo > b_prev ? std::log(b_lo / b_prev) / std::log(t_prev / lo) : 0.0;
          if (!saturated && p > 0.05)
            factor = std::min(16.0, std::max(1.5, std::pow(balls_wanted / std::max(b_lo, 0.5), 1.3 / p)));
          t_prev = lo;
          b_prev = b_lo;
          hi = lo;
          b_hi = b_lo;
          lo = std::max(lo / factor, lowest);
          b_lo = attempt(lo);
          const bool was_saturated = saturated;
          saturated = static_cast<double>(below_cap) < tol;
          // A smaller T that adds no ball, with balls below the cap: T cannot add more.
          if (b_lo <= b_hi && !(was_saturated || saturated))
            return best_distance < before;
        }
        if (b_lo < balls_wanted)
          return best_distance < before;
      }
      // Brent's method on g = log((count - floor) / (wanted - floor)) against log T, inside the
      // bracket: inverse quadratic interpolation where it behaves, bisection where it would not
      // (the count is a step function and bends where balls reach the cap). The floor is the
      // count the cap sets (the saturated count in this search, when below the wanted one; else
      // 0): above it the count falls about like a power of T.
      const double floor = floor_count < balls_wanted && floor_count <= b_hi ? std::max(0.0, floor_count - tol) : 0.0;
      auto gOf = [&](double b) { return std::log(std::max(b - floor, 0.5) / (balls_wanted - floor)); };
      double a = std::log(lo), fa = gOf(b_lo), b = std::log(hi), fb = gOf(b_hi);
      double c = a, fc = fa, d = b - a, e = d;
      const double x_tol = 1e-9;
      for (int it = 0; it < 40 && best_distance > tol; ++it)
      {
        if ((fb > 0.0) == (fc > 0.0))
        {
          c = a;
          fc = fa;
          d = e = b - a;
        }
        if (std::abs(fc) < std::abs(fb))
        {
          a = b;
          b = c;
          c = a;
          fa = fb;
          fb = fc;
          fc = fa;
        }
        const double xm = 0.5 * (c - b);
        if (std::abs(xm) <= x_tol || fb == 0.0)
          break;
        if (std::abs(e) >= x_tol && std::abs(fa) > std::abs(fb))
        {
          // Inverse quadratic interpolation (secant when only two points differ).
          const double s = fb / fa;
          double p, q;
          if (a == c)
          {
            p = 2.0 * xm * s;
            q = 1.0 - s;
          }
          else
          {
            const double qa = fa / fc, r = fb / fc;
            p = s * (2.0 * xm * qa * (qa - r) - (b - a) * (r - 1.0));
            q = (qa - 1.0) * (r - 1.0) * (s - 1.0);
          }
          if (p > 0.0)
            q = -q;
          p = std::abs(p);
          if (2.0 * p < std::min(3.0 * xm * q - std::abs(x_tol * q), std::abs(e * q)))
          {
            e = d;
            d = p / q;
          }
          else
          {
            d = xm;
            e = d;
          }
        }
        else
        {
          d = xm;
          e = d;
        }
        a = b;
        fa = fb;
        b += std::abs(d) > x_tol ? d : (xm > 0.0 ? x_tol : -x_tol);
        fb = gOf(attempt(std::exp(b)));
      }
      return best_distance < before;
    };
    // The gap bound widens by steps of 1.1. Once two searches at one cap have seen how the gap
    // points fall as the bound widens (about exponentially), several steps are taken at once: as
    // many as that trend says still leave at least the excess of gap points (never past the
    // bound it predicts, so the result is the one single steps would reach when the trend holds).
    struct GapTrial
    {
      double cap, gap, gaps, excess;
    };
    std::optional<GapTrial> previous;  // the last widening's search, when the gap points bound it
    auto widenGap = [&](bool gaps_bind) {
      if (!gaps_bind)
        return 1.1;
      const GapTrial b{cover_params.radius_cap_factor, gap_factor, static_cast<double>(fewest_gaps),
                       static_cast<double>(fewest) - balls_wanted};
      const std::optional<GapTrial> a = std::exchange(previous, b);
      if (!a || a->cap != b.cap)
        return 1.1;
      if (!(a->gaps > b.gaps && b.gaps > 0.0 && b.gap > a->gap && b.excess > 0.0 && b.gaps > b.excess))
        return 1.1;
      const double slope = std::log(b.gaps / a->gaps) / (b.gap - a->gap);  // < 0
      const double needed = b.gap + std::log((b.gaps - b.excess) / b.gaps) / slope;
      const double steps = std::floor(std::log(needed / b.gap) / std::log(1.1));
      return std::pow(1.1, std::min(8.0, std::max(1.0, steps)));
    };
    search();
    while (best_distance > tol)
    {
      // The size is out of reach: T_err cannot remove the points that the cap or the gap bound
      // forces. When the gap points alone exceed the excess, widen the gap bound (×1.1, up to the
      // cap); otherwise the cap (×1.5, targets close to the input size) up to the plain cap, the
      // gap bound following it. The closest result is kept.
      const bool gaps_bind = fewest != std::numeric_limits<std::size_t>::max() &&
                             static_cast<double>(fewest) > balls_wanted &&
                             static_cast<double>(fewest_gaps) >= static_cast<double>(fewest) - balls_wanted;
      if (gap_factor > 0.0 && gap_factor < cover_params.radius_cap_factor &&
          (gaps_bind || !(cover_params.radius_cap_factor < params.radius_cap_factor)))
        gap_factor = std::min(cover_params.radius_cap_factor, gap_factor * widenGap(gaps_bind));
      else if (cover_params.radius_cap_factor < params.radius_cap_factor)
      {
        cover_params.radius_cap_factor = std::min(params.radius_cap_factor, 1.5 * cover_params.radius_cap_factor);
        if (gap_factor > 0.0)
          gap_factor = std::max(gap_factor, gap_ratio * cover_params.radius_cap_factor);
      }
      else
        break;
      if (search())
        s.radius_cap_factor = cover_params.radius_cap_factor;
    }
  }
  s.timings.cover = secondsSince(t);
  report("cover", 1.0);

  s.balls = out.cover.balls.size();
  s.output_points = s.feature_points + s.balls;
  s.target_size = params.target_size;
  s.target_reached = params.target_size == 0 ||
                     std::abs(static_cast<double>(s.output_points) - static_cast<double>(params.target_size)) <=
                         0.01 * static_cast<double>(params.target_size);
  s.max_error = out.cover.max_error;
  s.radius_evaluations = out.cover.radius_evaluations;
  for (const auto& b : out.cover.balls)
  {
    s.centre_fallbacks += b.used_centre ? 1 : 0;
    s.rough_balls += tooRough(b, params) ? 1 : 0;
  }
  return Status::Ok;
}

double frameScale(double extent)
{
  if (extent >= std::ldexp(1.0, -20) && extent <= std::ldexp(1.0, 20))
    return 1.0;
  int e = 0;
  std::frexp(extent, &e);  // extent = m 2^e, m in [0.5, 1)
  const int k = 2 * static_cast<int>(std::floor(e / 2.0));  // even, so extent 2^-k is in [0.5, 2)
  return std::ldexp(1.0, -k);
}

void unscaleSummary(Summary& s, double scale)
{
  if (scale == 1.0)
    return;
  s.feature_threshold /= scale;
  s.mean_spacing /= scale;
  s.neighborhood_radius /= scale;
  s.bbox_diagonal /= scale;
  s.max_gap /= scale;
  s.mean_abs_curvature *= scale;
}

}  // namespace pcl_ecs
