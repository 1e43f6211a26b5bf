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

void candidatePlanes(const QuadricSamples& samples, const Eigen::Vector3d& centre,
                     const std::vector<BallCandidate>& sorted, std::vector<CandidatePlane>& planes)
{
  planes.resize(sorted.size());
  for (std::size_t i = 0; i < sorted.size(); ++i)
  {
    const auto j = static_cast<std::size_t>(sorted[i].index);
    const Eigen::Vector3d n = samples.normals[j].cast<double>();
    const Eigen::Vector3d offset = samples.cloud[j].getVector3fMap().cast<double>() - centre;
    planes[i] = {n, n.dot(offset), samples.weights[j], sorted[i].distance};
  }
}

RadiusEvaluation evaluateRadius(const std::vector<CandidatePlane>& planes, double r, double L,
                                ErrorForm form)
{
  RadiusEvaluation ev;
  ev.radius = r;
  const double R = 2.0 * r;
  Quadric q;
  for (const CandidatePlane& p : planes)
  {
    if (p.distance > R)
      break;
    const double w = p.weight * kernelG(p.distance, R);
    if (w > 0.0)
      q.addPlane(w, p.normal, p.offset);
  }
  ev.minimum = minimizeQuadric(q);
  ev.weight_sum = q.weight_sum;
  ev.error = errorOf(ev.minimum, q.weight_sum, L, form);
  return ev;
}

RadiusEvaluation evaluateRadius(const QuadricSamples& samples, const Eigen::Vector3d& centre,
                                const std::vector<BallCandidate>& sorted, double r, double L,
                                ErrorForm form)
{
  std::vector<CandidatePlane> planes;
  candidatePlanes(samples, centre, sorted, planes);
  return evaluateRadius(planes, r, L, form);
}

RadiusSolution solveRadius(const QuadricSamples& samples, const Eigen::Vector3d& centre,
                           double floor, double cap, double guess, double tolerance, double L,
                           ErrorForm form, CandidateSource& source,
                           std::vector<BallCandidate>& sorted)
{
  RadiusSolution sol;
  floor = std::min(std::max(floor, 0.0), cap);
  if (!(floor > 0.0))
    return sol;  // a duplicate of another point, or nothing around: the centre alone

  std::vector<CandidatePlane> planes;
  auto eval = [&](double r) {
    if (source.ensure(2.0 * r, sorted) || planes.size() != sorted.size())
      candidatePlanes(samples, centre, sorted, planes);
    ++sol.evaluations;
    return evaluateRadius(planes, r, L, form);
  };
  auto accept = [&](const RadiusEvaluation& ev) {
    if (ev.radius <= sol.radius)
      return;
    sol.radius = ev.radius;
    sol.error = ev.error;
    sol.x_min = ev.minimum.x;
  };

  double lo = -1.0, hi = -1.0;
  const double start = std::min(std::max(guess, floor), cap);
  const RadiusEvaluation first = eval(start);
  if (first.error <= tolerance)
  {
    accept(first);
    lo = start;
    // Grow until E exceeds the tolerance or the cap is reached.
    while (lo < cap)
    {
      const double r = std::min(lo * 1.25, cap);
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
  }
  else
  {
    hi = start;
    if (start > floor)
    {
      const RadiusEvaluation at_floor = eval(floor);
      if (at_floor.error <= tolerance)
      {
        accept(at_floor);
        lo = floor;
      }
    }
    if (lo < 0.0)
      return sol;  // even the smallest ball is too coarse here: keep the centre alone
  }
  // Bisect between the last good and the first bad radius; keep the largest good one.
  while (hi > 0.0 && hi - lo > 0.02 * hi)
  {
    const double mid = 0.5 * (lo + hi);
    const RadiusEvaluation ev = eval(mid);
    if (ev.error <= tolerance)
    {
      accept(ev);
      lo = mid;
    }
    else
      hi = mid;
  }
  return sol;
}

}  // namespace pcl_ecs
