#include <pcl_ecs/stages/ball_cover.h>

#include <pcl_ecs/stages/adaptive_tolerance.h>
#include <pcl_ecs/stages/hull_coverage.h>
#include <pcl_ecs/stages/kernel.h>
#include <pcl_ecs/stages/radius_solver.h>
#include <pcl_ecs/stages/seeded_order.h>

#include <algorithm>
#include <cmath>

namespace pcl_ecs
{

namespace
{
/// Candidates of one ball from a radius search over the non-feature points, grown on demand.
class RadiusQuerySource : public CandidateSource
{
public:
  RadiusQuerySource(const pcl::search::Search<pcl::PointXYZ>& search, const pcl::PointXYZ& centre,
                    double max_radius, double first_radius)
    : search_(search), centre_(centre), max_radius_(max_radius), next_radius_(first_radius)
  {
  }

  bool ensure(double needed, std::vector<BallCandidate>& sorted) override
  {
    if (needed <= queried_)
      return false;
    double radius = std::min(max_radius_, std::max(needed, next_radius_));
    search_.radiusSearch(centre_, radius, found_, d2_);
    sorted.clear();
    sorted.reserve(found_.size());
    for (std::size_t i = 0; i < found_.size(); ++i)
      sorted.push_back({std::sqrt(static_cast<double>(d2_[i])), found_[i]});
    std::sort(sorted.begin(), sorted.end());
    // Anything at or below the radius asked for is complete; tell the solver so.
    queried_ = radius >= max_radius_ ? std::numeric_limits<double>::infinity() : radius;
    next_radius_ = 1.5 * radius;
    return true;
  }

private:
  const pcl::search::Search<pcl::PointXYZ>& search_;
  pcl::PointXYZ centre_;
  double max_radius_;
  double next_radius_;
  double queried_ = -1.0;
  pcl::Indices found_;
  std::vector<float> d2_;
};
}  // namespace

void coverWithBalls(const CoverInput& in, const Parameters& params, double error_threshold,
                    CoverOutput& out)
{
  const std::size_t n = in.cloud.size();
  out = CoverOutput{};
  out.owner.assign(n, -1);

  std::vector<int> order;
  order.reserve(n);
  for (std::size_t i = 0; i < n; ++i)
    if (!in.is_feature[i])
      order.push_back(static_cast<int>(i));
  seededShuffle(order, params.seed);

  const double cap = std::max(params.radius_cap_factor * in.neighborhood_radius, 0.0);
  const QuadricSamples samples{in.cloud, in.normals, in.weights};
  std::vector<BallCandidate> sorted;
  std::vector<Eigen::Vector3d> offsets;
  std::vector<int> members;
  std::vector<std::uint8_t> inside;
  double typical_radius = in.neighborhood_radius;  // first query guess; adapts to recent balls

  for (const int c : order)
  {
    if (out.owner[static_cast<std::size_t>(c)] >= 0)
      continue;
    const std::size_t cs = static_cast<std::size_t>(c);
    const int ball_id = static_cast<int>(out.balls.size());
    CoverBall ball;
    ball.centre = c;
    ball.tolerance = adaptTolerance(error_threshold, params.adaptive, params.adaptive_factor,
                                    in.curvature[cs], in.mean_abs_curvature, in.density[cs],
                                    in.mean_density);
    const Eigen::Vector3d centre = in.cloud[c].getVector3fMap().cast<double>();

    // Steps 4-5: the radius and the optimised point. The floor is dens_c (eq. 5), the cap a
    // multiple of the mean spacing.
    const double guess = std::max(typical_radius, in.density[cs]);
    RadiusQuerySource source(in.nonfeature_search, in.cloud[c], 2.0 * cap, 2.0 * 1.25 * guess);
    sorted.clear();
    const RadiusSolution sol = solveRadius(samples, centre, in.density[cs], cap, guess,
                                           ball.tolerance, in.bbox_diagonal, params.error_form,
                                           source, sorted);
    out.radius_evaluations += static_cast<std::size_t>(sol.evaluations);
    ball.radius = sol.radius;
    ball.error = sol.error;
    if (sol.radius > 0.0)
      typical_radius = 0.9 * typical_radius + 0.1 * sol.radius;

    ball.used_centre = !(sol.x_min.norm() < sol.radius);
    const Eigen::Vector3d v_offset = ball.used_centre ? Eigen::Vector3d::Zero() : sol.x_min;
    ball.representative = centre + v_offset;

    // Members: the non-feature points within r (c among them, at distance 0).
    offsets.clear();
    members.clear();
    for (const BallCandidate& cand : sorted)
    {
      if (cand.distance > sol.radius)
        break;
      members.push_back(cand.index);
      offsets.push_back(in.cloud[cand.index].getVector3fMap().cast<double>() - centre);
    }
    if (members.empty() || std::find(members.begin(), members.end(), c) == members.end())
    {
      members.push_back(c);
      offsets.push_back(Eigen::Vector3d::Zero());
    }

    // Attributes: from the member nearest to v; normal averaged over the ball with c's sign.
    const Eigen::Vector3d nc = in.normals[cs].cast<double>();
    Eigen::Vector3d normal_sum = Eigen::Vector3d::Zero();
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t m = 0; m < members.size(); ++m)
    {
      const double d = (offsets[m] - v_offset).squaredNorm();
      if (d < best || (d == best && members[m] < ball.attribute_source))
      {
        best = d;
        ball.attribute_source = members[m];
      }
      Eigen::Vector3d nm = in.normals[static_cast<std::size_t>(members[m])].cast<double>();
      if (nm.dot(nc) < 0.0)
        nm = -nm;
      const double w = sol.radius > 0.0 ? kernelG(offsets[m].norm(), sol.radius) : 1.0;
      normal_sum += w * nm;
    }
    const double len = normal_sum.norm();
    ball.normal = (len > 0.0 ? Eigen::Vector3d(normal_sum / len) : nc).cast<float>();

    // Step 6: cover c and the members projected strictly inside the hull.
    auto claim = [&](int idx) {
      int& owner = out.owner[static_cast<std::size_t>(idx)];
      if (owner < 0)
      {
        owner = ball_id;
        ++ball.replaced;
      }
    };
    claim(c);
    if (members.size() >= 3)
    {
      hullCoverage(nc, offsets, inside);
      for (std::size_t m = 0; m < members.size(); ++m)
        if (inside[m])
          claim(members[m]);
    }
    out.max_error = std::max(out.max_error, ball.error);
    out.balls.push_back(ball);
  }
}

}  // namespace pcl_ecs
