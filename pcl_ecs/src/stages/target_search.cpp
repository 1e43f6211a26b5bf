#include <pcl_ecs/stages/target_search.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace pcl_ecs
{

namespace
{
constexpr double lowest = 1e-12, highest = 0.999;  // the range of T_err searched

/// One run of the search (target_search.h); the state its steps share.
class Search
{
public:
  Search(const TargetSearchSetup& setup, TargetCounter& counter)
    : setup_(setup), counter_(counter), target_(setup.target),
      full_(setup.target - static_cast<double>(setup.fixed_points)),
      band_(std::max(0.0, std::min(0.5, setup.top_up))), wanted_(full_ * (1.0 - 0.5 * band_)),
      tol_(0.01 * setup.target),
      cap_(setup.cap_factor), gap_factor_(setup.gap_ratio * setup.cap_factor)
  {
    r_.cap_factor = cap_;
  }

  TargetSearchResult run();

private:
  double attempt(double terr);
  bool search();
  bool bracketUp(double& lo, double& hi, double& b_lo, double& b_hi);
  bool bracketDown(double& lo, double& hi, double& b_lo, double& b_hi);
  void solve(double lo, double hi, double b_lo, double b_hi);
  double widenGap(bool gaps_bind);
  double widenCap() const;
  std::optional<double> predictedTerr(double from, double from_count);
  double keptOnTheWay(double from, double to) const;

  const TargetSearchSetup& setup_;
  TargetCounter& counter_;
  // Output points and balls wanted; the top-up band (a fraction of the balls wanted); the balls
  // the search steers to (wanted less half the band, so that a trial on either side of it ends
  // the search); the 1% tolerance.
  const double target_, full_, band_, wanted_, tol_;
  double cap_, gap_factor_;             // the current cap and gap bound
  TargetSearchResult r_;
  double best_distance_ = std::numeric_limits<double>::infinity();
  // The fewest balls the current search reached, and how many of them closed gaps.
  std::size_t fewest_ = std::numeric_limits<std::size_t>::max(), fewest_gaps_ = 0;
  // Balls of the last cover below the radius cap: when they are fewer than the tolerance, a
  // larger T cannot remove enough balls (every other ball is at the cap already).
  std::size_t below_cap_ = 0;
  double last_count_ = 0.0;    // the last trial's count (its T is tried_.back())
  std::vector<double> tried_;  // every T tried, in order
  double least_terr_at_cap_ = std::numeric_limits<double>::infinity();  // of the trials at the current cap
  // How much more the count moved than the counter predicted, measured on the last predicted step
  // (log of the change seen over log of the change predicted; 1 until a step measures it), and the
  // step waiting for its count.
  double sensitivity_ = 1.0;
  struct PendingPrediction
  {
    double terr, from_count, predicted;
  };
  std::optional<PendingPrediction> pending_;
  // The count at saturation in the current search (cap and gap bound): the fewest balls of a
  // cover whose balls are nearly all at the cap.
  double floor_count_ = std::numeric_limits<double>::infinity();
  // Where a search found the count saturated (the same at T and 4 T: every ball at the cap), per
  // cap: a later search at that cap (a wider gap bound) that starts at or above that T with too
  // many balls is saturated too, and need not probe 4 T again.
  double saturated_cap_ = -1.0, saturated_terr_ = highest;
  // The gap bound's last widening, when the gap points bound the count (widenGap).
  struct GapTrial
  {
    double cap, gap, gaps, excess;
  };
  std::optional<GapTrial> previous_;
};

/// One trial: the count at T_err `terr` with the current cap and gap bound; the best so far kept.
double Search::attempt(double terr)
{
  const TargetTrialCounts c = counter_.count(terr, cap_, gap_factor_);
  below_cap_ = c.below_cap;
  const std::size_t balls = c.balls;
  if (pending_ && pending_->terr == terr)
  {
    const double seen = std::log(static_cast<double>(std::max<std::size_t>(balls, 1)) / pending_->from_count);
    const double predicted = std::log(pending_->predicted / pending_->from_count);
    if (std::abs(predicted) > 0.005 && seen / predicted > 0.0)
      sensitivity_ = std::min(4.0, std::max(0.5, seen / predicted));
  }
  pending_.reset();
  last_count_ = static_cast<double>(balls);
  tried_.push_back(terr);
  ++r_.trials;
  // Nearly saturated (at most 5% of the balls, or the tolerance, below the cap): about the
  // count the cap sets.
  const bool nearly_saturated =
      static_cast<double>(below_cap_) < std::max(0.01 * target_, 0.05 * static_cast<double>(balls));
  if (nearly_saturated)
    floor_count_ = std::min(floor_count_, static_cast<double>(balls));
  if (balls < fewest_)
  {
    fewest_ = balls;
    fewest_gaps_ = c.gap_points;
  }
  // Short of the size by at most the top-up band: the counter adds the missing points.
  std::size_t topped = 0;
  const double shortfall = std::round(full_) - static_cast<double>(balls);
  // Not a cover whose balls are nearly all at the cap, unless a smaller T at this cap was tried
  // before (the cap, not T, sets the size there): from the starting T a smaller one may still
  // shrink the balls where the surface bends.
  const bool smaller_tried = least_terr_at_cap_ < terr;
  least_terr_at_cap_ = std::min(least_terr_at_cap_, terr);
  if (shortfall >= 1.0 && shortfall <= band_ * full_ && (!nearly_saturated || smaller_tried))
    topped = counter_.topUp(static_cast<std::size_t>(shortfall));
  const double distance = std::abs(static_cast<double>(setup_.fixed_points + balls + topped) - target_);
  if (distance < best_distance_)
  {
    best_distance_ = distance;
    r_.terr = terr;
    r_.top_up_points = topped;
    r_.gap_points = c.gap_points;
    r_.gap_factor = gap_factor_;
    r_.output_points = setup_.fixed_points + balls + topped;
    counter_.keepLast();
  }
  return static_cast<double>(balls);
}

/// Too many balls at `lo`: T up by ×4 until too few (the bracket [lo, hi]). False when the count
/// saturates first (a count that changes by less than the tolerance while T moves by 4×, or a
/// cover whose balls are all at the cap: the cap, not T, sets it) or T reaches its top.
bool Search::bracketUp(double& lo, double& hi, double& b_lo, double& b_hi)
{
  int predicted_steps = 0;  // in a row
  while (b_hi > wanted_ && hi < highest && best_distance_ > tol_)
  {
    lo = hi;
    b_lo = b_hi;
    const std::optional<double> guess = predicted_steps < 2 ? predictedTerr(hi, b_hi) : std::nullopt;
    const bool predicted = guess && *guess > hi;
    predicted_steps = predicted ? predicted_steps + 1 : 0;
    hi = std::min(predicted ? keptOnTheWay(hi, *guess) : hi * 4.0, highest);
    b_hi = attempt(hi);
    // Saturated: the balls below the cap are too few to matter, or T × 4 removed fewer
    // balls than the tolerance (every ball near the cap).
    if (b_hi > wanted_ && (static_cast<double>(below_cap_) < tol_ || (!predicted && b_hi > b_lo - tol_)))
    {
      saturated_cap_ = cap_;
      saturated_terr_ = static_cast<double>(below_cap_) < tol_ ? hi : lo;
      return false;
    }
  }
  if (b_hi > wanted_)
    return false;
  return true;
}

/// Too few balls at `hi` (= lo on entry): T down until too many (the bracket [lo, hi]). False when a
/// smaller T adds no ball or T reaches its bottom.
bool Search::bracketDown(double& lo, double& hi, double& b_lo, double& b_hi)
{
  // Too few balls. Down by ×4 while the cover is saturated (every ball at the cap: the count
  // stays put until T is small enough to shrink balls); then, from two trials, by the step
  // their power law gives to the wanted count, passed by 30% to bracket it (1.5 to 16).
  double t_prev = hi, b_prev = b_hi;
  bool saturated = static_cast<double>(below_cap_) < tol_;
  int predicted_steps = 0;  // in a row
  while (b_lo < wanted_ && lo > lowest && best_distance_ > tol_)
  {
    double factor = 4.0;
    const double p = t_prev != lo && b_prev > 0.0 && b_lo > b_prev ? std::log(b_lo / b_prev) / std::log(t_prev / lo) : 0.0;
    const std::optional<double> guess = predicted_steps < 2 ? predictedTerr(lo, b_lo) : std::nullopt;
    const bool predicted = guess && *guess < lo;
    predicted_steps = predicted ? predicted_steps + 1 : 0;
    if (predicted)
      factor = lo / keptOnTheWay(lo, *guess);
    else if (!saturated && p > 0.05)
      factor = std::min(16.0, std::max(1.5, std::pow(wanted_ / std::max(b_lo, 0.5), 1.3 / p)));
    t_prev = lo;
    b_prev = b_lo;
    hi = lo;
    b_hi = b_lo;
    lo = std::max(lo / factor, lowest);
    b_lo = attempt(lo);
    const bool was_saturated = saturated;
    saturated = static_cast<double>(below_cap_) < tol_;
    // A smaller T that adds no ball, with balls below the cap: T cannot add more (unless the
    // step was a prediction's, which may be short).
    if (b_lo <= b_hi && !(was_saturated || saturated) && !predicted)
      return false;
  }
  if (b_lo < wanted_)
    return false;
  return true;
}

/// The T_err within ×16 of `from` (whose trial counted `from_count`) at which the counter's
/// prediction from its last cover gives the wanted count, the predicted change scaled by the
/// sensitivity measured so far; nothing when it cannot predict or the count lies outside that
/// range. Bisection on log T (the prediction falls as T rises, but for the gap points it carries).
std::optional<double> Search::predictedTerr(double from, double from_count)
{
  if (!(from_count > 0.0) || !(wanted_ > 0.0))
    return std::nullopt;
  const double want = from_count * std::pow(wanted_ / from_count, 1.0 / sensitivity_);
  double a = std::max(from / 16.0, lowest), b = std::min(from * 16.0, highest);
  const double at_a = counter_.predictCount(a), at_b = counter_.predictCount(b);
  if (std::isnan(at_a) || std::isnan(at_b) || !(at_a >= want && want >= at_b))
    return std::nullopt;
  for (int it = 0; it < 40 && b > a * (1.0 + 1e-4); ++it)
  {
    const double m = std::sqrt(a * b);
    (counter_.predictCount(m) >= want ? a : b) = m;
  }
  const double t = std::sqrt(a * b);
  pending_ = PendingPrediction{t, from_count, counter_.predictCount(t)};
  return t;
}

/// `to`, or the T strictly between `from` and `to` nearest to `to` whose cover at the current cap
/// the counter keeps: that trial is cheap, and when the prediction overshoots it is closer.
double Search::keptOnTheWay(double from, double to) const
{
  double best = to;
  for (const double t : tried_)
    if (std::min(from, to) < t && t < std::max(from, to) && counter_.keepsCover(t, cap_) &&
        (best == to || std::abs(std::log(t / to)) < std::abs(std::log(best / to))))
      best = t;
  return best;
}

/// Brent's method on g = log((count - floor) / (wanted - floor)) against log T, inside the
/// bracket: inverse quadratic interpolation where it behaves, bisection where it would not (the
/// count is a step function and bends where balls reach the cap). The floor is the count the cap
/// sets (the saturated count in this search, when below the wanted one; else 0): above it the
/// count falls about like a power of T.
void Search::solve(double lo, double hi, double b_lo, double b_hi)
{
  // First, up to two steps to the T the last trial's cover predicts, while that falls inside
  // the bracket.
  for (int k = 0; k < 2 && best_distance_ > tol_; ++k)
  {
    const std::optional<double> guess = predictedTerr(tried_.back(), last_count_);
    if (!guess || !(*guess > lo && *guess < hi))
      break;
    const double b = attempt(*guess);
    (b > wanted_ ? lo : hi) = *guess;
    (b > wanted_ ? b_lo : b_hi) = b;
  }
  if (best_distance_ <= tol_)
    return;
  const double floor = floor_count_ < wanted_ && floor_count_ <= b_hi ? std::max(0.0, floor_count_ - tol_) : 0.0;
  auto gOf = [&](double b) { return std::log(std::max(b - floor, 0.5) / (wanted_ - floor)); };
  double a = std::log(lo), fa = gOf(b_lo), b = std::log(hi), fb = gOf(b_hi);
  double c = a, fc = fa, d = b - a, e = d;
  const double x_tol = 1e-9;
  for (int it = 0; it < 40 && best_distance_ > tol_; ++it)
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
        const double qa = fa / fc, rb = fb / fc;
        p = s * (2.0 * xm * qa * (qa - rb) - (b - a) * (rb - 1.0));
        q = (qa - 1.0) * (rb - 1.0) * (s - 1.0);
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
}

/// One search at the current cap and gap bound: bracket T, then solve inside the bracket. True
/// when it found a closer size than the searches before.
bool Search::search()
{
  const double before = best_distance_;
  floor_count_ = std::numeric_limits<double>::infinity();
  fewest_ = std::numeric_limits<std::size_t>::max();
  // The first search starts at the user's T_err, a later one (wider gap or cap) at the best so far.
  const double start = std::isfinite(best_distance_) ? r_.terr : setup_.start_terr;
  double lo = std::min(std::max(start, lowest), highest);  // T giving too many
  double hi = lo;                                          // T giving too few
  double b_lo = attempt(lo), b_hi = b_lo;
  if (best_distance_ <= tol_)
    return best_distance_ < before;
  if (b_lo > wanted_ && cap_ == saturated_cap_ && lo >= saturated_terr_)
    return best_distance_ < before;
  // Saturated: (nearly) every ball at the cap, so a larger T changes little: growing the balls
  // below the cap to it removes at most about as many balls as there are below it. (Not when the
  // gap points come near the excess: a wider gap bound may then reach the size at this cap.)
  if (b_lo > wanted_ && (static_cast<double>(below_cap_) < tol_ ||
                         (static_cast<double>(below_cap_) < 0.05 * b_lo &&
                          b_lo - static_cast<double>(below_cap_) > 1.2 * wanted_ &&
                          static_cast<double>(fewest_gaps_) < 0.75 * (b_lo - wanted_))))
  {
    saturated_cap_ = cap_;
    saturated_terr_ = lo;
    return best_distance_ < before;
  }
  // Too many, and the gap points alone exceed the excess while the gap bound may widen: widen it
  // first (run()), here at this T, whose cover is reused, rather than move T.
  if (b_lo > wanted_ && gap_factor_ > 0.0 && gap_factor_ < cap_ &&
      static_cast<double>(fewest_gaps_) >= b_lo - wanted_)
    return best_distance_ < before;
  const bool bracketed = b_lo > wanted_ ? bracketUp(lo, hi, b_lo, b_hi) : bracketDown(lo, hi, b_lo, b_hi);
  if (bracketed)
    solve(lo, hi, b_lo, b_hi);
  return best_distance_ < before;
}

/// The gap bound widens by steps of 1.1. Once two searches at one cap have seen how the gap
/// points fall as the bound widens (about exponentially), several steps are taken at once: as
/// many as that trend says still leave at least the excess of gap points (never past the bound
/// it predicts, so the result is the one single steps would reach when the trend holds).
double Search::widenGap(bool gaps_bind)
{
  if (!gaps_bind)
    return 1.1;
  const GapTrial b{cap_, gap_factor_, static_cast<double>(fewest_gaps_), static_cast<double>(fewest_) - wanted_};
  const std::optional<GapTrial> a = std::exchange(previous_, b);
  if (!a || a->cap != b.cap)
    return 1.1;
  if (!(a->gaps > b.gaps && b.gaps > 0.0 && b.gap > a->gap && b.excess > 0.0 && b.gaps > b.excess))
    return 1.1;
  const double slope = std::log(b.gaps / a->gaps) / (b.gap - a->gap);  // < 0
  const double needed = b.gap + std::log((b.gaps - b.excess) / b.gaps) / slope;
  const double steps = std::floor(std::log(needed / b.gap) / std::log(1.1));
  return std::pow(1.1, std::min(8.0, std::max(1.0, steps)));
}

/// The cap widens by steps of 1.5, several at once: as many as a count falling by 2.4 per step
/// would need to come from the fewest balls of this search, less their gap points, down to the
/// wanted count. A saturated count falls by 1.9-2.3 per step on the shared scans (each ball at the
/// cap covers about cap²), and the gap bound widens at the new cap as at this one (run()), so
/// single steps would need at least as many: the cap is not past the one they would stop at.
double Search::widenCap() const
{
  if (fewest_ == std::numeric_limits<std::size_t>::max() || !(static_cast<double>(fewest_) > wanted_) ||
      !(wanted_ > 0.0))
    return 1.5;
  const double balls = std::max(wanted_, static_cast<double>(fewest_ - std::min(fewest_, fewest_gaps_)));
  const double steps = std::ceil(std::log(balls / wanted_) / std::log(2.4));
  return std::pow(1.5, std::min(8.0, std::max(1.0, steps)));
}

TargetSearchResult Search::run()
{
  search();
  while (best_distance_ > tol_)
  {
    // The size is out of reach: T_err cannot remove the points that the cap or the gap bound
    // forces. When the gap points alone exceed the excess, widen the gap bound (×1.1, up to the
    // cap); otherwise the cap (×1.5, targets close to the input size) up to the plain cap, the
    // gap bound following it. The closest result is kept.
    const bool gaps_bind = fewest_ != std::numeric_limits<std::size_t>::max() &&
                           static_cast<double>(fewest_) > wanted_ &&
                           static_cast<double>(fewest_gaps_) >= static_cast<double>(fewest_) - wanted_;
    if (gap_factor_ > 0.0 && gap_factor_ < cap_ && (gaps_bind || !(cap_ < setup_.max_cap_factor)))
      gap_factor_ = std::min(cap_, gap_factor_ * widenGap(gaps_bind));
    else if (cap_ < setup_.max_cap_factor)
    {
      cap_ = std::min(setup_.max_cap_factor, widenCap() * cap_);
      least_terr_at_cap_ = std::numeric_limits<double>::infinity();
      if (gap_factor_ > 0.0)
        gap_factor_ = std::max(gap_factor_, setup_.gap_ratio * cap_);
    }
    else
      break;
    if (search())
      r_.cap_factor = cap_;
  }
  r_.reached = best_distance_ <= tol_;
  return r_;
}
}  // namespace

TargetSearchResult searchTargetSize(const TargetSearchSetup& setup, TargetCounter& counter)
{
  return Search(setup, counter).run();
}

}  // namespace pcl_ecs
