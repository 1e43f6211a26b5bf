#include <pcl_ecs/stages/radius_solver.h>

#include <pcl_ecs/stages/kernel.h>

#include <algorithm>
#include <cmath>

namespace pcl_ecs
{

double errorOf(const QuadricMinimum& minimum, double weight_sum, double L, ErrorForm form)
{
  if (!(weight_sum > 0.0) || !(L > 0.0))
    return 0.0;
  const double q = std::max(0.0, minimum.value);
  return form == ErrorForm::Paper ? std::sqrt(q) / L : std::sqrt(q / weight_sum) / L;
}

RadiusEvaluation evaluateRadius(const QuadricSamples& samples, const Eigen::Vector3d& centre,
                                const std::vector<BallCandidate>& sorted, double r, double L,
                                ErrorForm form)
{
  RadiusEvaluation ev;
  ev.radius = r;
  const double R = 2.0 * r;
  Quadric q;
  for (const BallCandidate& cand : sorted)
  {
    if (cand.distance > R)
      break;
    const double w =
        samples.weights[static_cast<std::size_t>(cand.index)] * kernelG(cand.distance, R);
    if (w <= 0.0)
      continue;
    const Eigen::Vector3d offset =
        samples.cloud[cand.index].getVector3fMap().cast<double>() - centre;
    q.add(w, samples.normals[static_cast<std::size_t>(cand.index)].cast<double>(), offset);
  }
  ev.minimum = minimizeQuadric(q);
  ev.weight_sum = q.weight_sum;
  ev.error = errorOf(ev.minimum, q.weight_sum, L, form);
  return ev;
}

RadiusSolution solveRadius(const QuadricSamples& samples, const Eigen::Vector3d& centre,
                           double floor, double cap, double tolerance, double L, ErrorForm form,
                           CandidateSource& source, std::vector<BallCandidate>& sorted)
{
  RadiusSolution sol;
  floor = std::min(std::max(floor, 0.0), cap);
  if (!(floor > 0.0))
    return sol;  // a duplicate of another point, or nothing around: the centre alone

  auto eval = [&](double r) {
    source.ensure(2.0 * r, sorted);
    ++sol.evaluations;
    return evaluateRadius(samples, centre, sorted, r, L, form);
  };
  auto accept = [&](const RadiusEvaluation& ev) {
    sol.radius = ev.radius;
    sol.error = ev.error;
    sol.x_min = ev.minimum.x;
  };

  const RadiusEvaluation at_floor = eval(floor);
  if (at_floor.error > tolerance)
    return sol;  // even the smallest ball is too coarse here: keep the centre alone
  accept(at_floor);

  // Bracket: grow until E exceeds the tolerance or the cap is reached.
  double lo = floor;
  double hi = -1.0;
  while (lo < cap)
  {
    const double r = std::min(lo * 1.5, cap);
    const RadiusEvaluation ev = eval(r);
    if (ev.error <= tolerance)
    {
      accept(ev);
      lo = r;
    }
    else
    {
      hi = r;
      break;
    }
  }
  // Bisect between the last good and the first bad radius; keep the largest good one.
  for (int it = 0; hi > 0.0 && it < 12 && hi - lo > 1e-3 * hi; ++it)
  {
    const double mid = 0.5 * (lo + hi);
    const RadiusEvaluation ev = eval(mid);
    if (ev.error <= tolerance)
    {
      if (mid > sol.radius)
        accept(ev);
      lo = mid;
    }
    else
    {
      hi = mid;
    }
  }
  return sol;
}

}  // namespace pcl_ecs
