// target_search.h — "give me N points": the T_err (and, when T_err alone cannot, the radius cap and
// the gap bound) whose cover gives N output points within 1%, or the closest size reachable.
//
// The search knows nothing of points: it asks a count function for the size of the cover at a
// (T_err, cap, gap) and tells it which trial is the best so far. The method's driver runs the
// cover (ball_cover.h) and the gap bound (gap_fill.h) behind that function and keeps the best
// output; a test gives it a synthetic count.
//
// The search, in order:
//  0. too many at the start, and the gap points alone more than the excess: the gap bound widens
//     first (as in 2), at the starting T_err, whose cover the counter reuses;
//  1. at the starting cap and gap bound: bracket T_err from the starting T_err (the filter's is
//     4e-3), each step to the T_err the counter predicts from its last cover for the wanted count
//     (TargetCounter::predictCount, its change scaled by how far the last predicted step missed;
//     at most twice in a row, and never by more than ×16; a T_err on the way whose cover the
//     counter keeps is tried first), else by ×4 (down by the step two trials' power law gives,
//     when too few); then, inside the bracket, up to two predicted steps and Brent's method on
//     log((count − floor) / (wanted − floor)) against log T;
//  A trial short of the wanted balls by at most TargetSearchSetup::top_up of them is finished by
//  TargetCounter::topUp (the counter adds the missing points) and ends the search, unless nearly
//  all its balls are at the cap and no smaller T was tried at that cap (a smaller T may still
//  shrink balls where the surface bends); the steps above steer to the middle of that band.
//  2. while the size is out of reach (the cap or the gap points, not T_err, set the count): widen
//     the gap bound (×1.1, several steps at once when two searches show how the gap points fall)
//     when the gap points alone exceed the excess, else the cap (×1.5, up to the widest cap;
//     several steps at once when the fewest balls so far, less their gap points, are more than
//     2.4 × the wanted count),
//     and search again from the best T_err so far. A search is over at its first trial when
//     that cover is saturated: too many balls, and fewer than 1% of the target below the cap, or
//     fewer than 5% of the balls below it while the balls at the cap alone exceed the wanted
//     count by 20% and the gap points are less than 3/4 of the excess.
// The result is a function of the counts alone, so it is deterministic when the count is.
#pragma once

#include <cstddef>
#include <limits>

namespace pcl_ecs
{

/** \brief What one cover gave at a (T_err, cap, gap) trial. */
struct TargetTrialCounts
{
  std::size_t balls = 0;      ///< balls of the cover after the gap bound (gap points included)
  std::size_t gap_points = 0; ///< of those, the ones the gap bound added
  std::size_t below_cap = 0;  ///< balls of the cover (before the gap bound) whose radius is below the cap
};

/** \brief The count function the search drives. */
class TargetCounter
{
public:
  virtual ~TargetCounter() = default;
  /// The cover at T_err `terr`, radius cap `cap_factor` and gap bound `gap_factor` (both in
  /// neighbourhood radii); the counter keeps its output as "the last trial".
  virtual TargetTrialCounts count(double terr, double cap_factor, double gap_factor) = 0;
  /// The last trial is the closest to the target so far: keep it as the result.
  virtual void keepLast() = 0;
  /// The count (TargetTrialCounts::balls) a trial at T_err `terr` would give at the last trial's
  /// cap and gap bound, predicted from the last trial without running a cover; NaN when the
  /// counter cannot tell (the default). The search steps to the T_err it predicts for the wanted
  /// count instead of by ×4 (see above).
  virtual double predictCount(double terr) const
  {
    (void)terr;
    return std::numeric_limits<double>::quiet_NaN();
  }
  /// Adds `points` output points to the last trial (before keepLast is called for it) and returns
  /// how many it added; 0 (the default) when it cannot. The search asks for it when the last
  /// trial is short of the size by at most TargetSearchSetup::top_up.
  virtual std::size_t topUp(std::size_t points)
  {
    (void)points;
    return 0;
  }
  /// Whether a trial at (`terr`, `cap_factor`) would reuse a cover the counter keeps (a cheap
  /// trial); false by default.
  virtual bool keepsCover(double terr, double cap_factor) const
  {
    (void)terr;
    (void)cap_factor;
    return false;
  }
};

/** \brief Where the search starts. */
struct TargetSearchSetup
{
  double target = 0;             ///< output points wanted (fixed points + balls)
  std::size_t fixed_points = 0;  ///< output points every trial has (the feature points)
  double start_terr = 1e-3;      ///< the first T_err tried
  double cap_factor = 5;         ///< the radius cap the target implies (neighbourhood radii)
  double max_cap_factor = 5;     ///< the widest cap the search may reach (the plain radius cap)
  double gap_ratio = 0.6;        ///< the gap bound as a multiple of the cap (0: no gap bound)
  /// A trial short of the wanted balls by at most this fraction of them (up to 0.5) is finished
  /// by TargetCounter::topUp, and the search steers to the middle of that band; 0: never.
  double top_up = 0.0;
};

/** \brief The best trial. */
struct TargetSearchResult
{
  double terr = 0;               ///< its T_err
  double cap_factor = 0;         ///< the cap of the last search that improved on the one before
  double gap_factor = 0;         ///< its gap bound, in neighbourhood radii
  std::size_t gap_points = 0;    ///< its gap points
  std::size_t top_up_points = 0; ///< the points TargetCounter::topUp added to it
  std::size_t output_points = 0; ///< fixed points + its balls
  int trials = 0;                ///< count() calls
  bool reached = false;          ///< within 1% of the target
};

/** \brief Search as described above; `counter` is called for every trial and told of every new
 * best one. At least one trial is made. */
TargetSearchResult searchTargetSize(const TargetSearchSetup& setup, TargetCounter& counter);

}  // namespace pcl_ecs
