// Template definitions of FeatureAwareCoverSimplify (see the header).
#pragma once

#include <pcl_ecs/feature_aware_cover_simplify.h>
#include <pcl_ecs/spatial_order.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <limits>

#include <pcl/common/io.h>
#include <pcl/common/point_tests.h>
#include <pcl/console/print.h>
#include <pcl/point_traits.h>
#include <pcl/type_traits.h>

namespace pcl_ecs
{

namespace detail
{
template <typename PointT>
void setNormal(PointT& p, const Eigen::Vector3f& n)
{
  if constexpr (pcl::traits::has_normal_v<PointT>)
  {
    p.normal_x = n.x();
    p.normal_y = n.y();
    p.normal_z = n.z();
  }
  else
  {
    (void)p;
    (void)n;
  }
}

template <typename PointT>
Eigen::Vector3f getNormal(const PointT& p)
{
  if constexpr (pcl::traits::has_normal_v<PointT>)
    return Eigen::Vector3f(p.normal_x, p.normal_y, p.normal_z);
  else
  {
    (void)p;
    return Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  }
}
}  // namespace detail

template <typename PointT>
bool FeatureAwareCoverSimplify<PointT>::validateForRun(std::string& why) const
{
  why = validate(params_);
  if (!why.empty())
    return false;
  if (params_.use_input_normals && !pcl::traits::has_normal_v<PointT>)
  {
    why = "use_input_normals is set but the point type carries no normals";
    return false;
  }
  return true;
}

template <typename PointT>
void FeatureAwareCoverSimplify<PointT>::applyFilter(PointCloud& output)
{
  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  // Clear before anything can fail: PCL would otherwise leave the caller's old output in place.
  output.clear();
  output.width = 0;
  output.height = 1;
  output.is_dense = true;
  result_.clear();

  auto fail = [&](const std::string& why) {
    PCL_ERROR("[pcl_ecs::%s::applyFilter] %s\n", filter_name_.c_str(), why.c_str());
    output.clear();
    output.width = 0;
    output.height = 1;
    result_.error = why;
  };

  std::string why;
  if (!validateForRun(why))
    return fail(why);

  try
  {
    // 1. Finite points of the indices, in a local frame (double origin) for float precision.
    const auto t_prep = Clock::now();
    std::vector<int> used;  // local index -> input index
    used.reserve(indices_->size());
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    Eigen::Vector3d hi = -lo;
    for (const auto idx : *indices_)
    {
      const PointT& p = (*input_)[idx];
      // Checked whatever is_dense says: a cloud that claims to be dense may not be.
      if (!pcl::isXYZFinite(p))
        continue;
      if (params_.use_input_normals && !detail::getNormal(p).allFinite())
        continue;
      used.push_back(static_cast<int>(idx));
      const Eigen::Vector3d q(p.x, p.y, p.z);
      lo = lo.cwiseMin(q);
      hi = hi.cwiseMax(q);
    }
    result_.summary.input_points = indices_->size();
    result_.summary.finite_points = used.size();
    if (used.empty())
      return fail("the input has no finite points");
    if (lo == hi && used.size() > 1)
      return fail("all points are identical: there is no surface to simplify");
    // Store the points in Hilbert order: every neighbour query of every stage is then local.
    const auto position = [&](int idx) {
      const PointT& p = (*input_)[idx];
      return Eigen::Vector3d(p.x, p.y, p.z);
    };
    // Coincident points (merged scans, re-exports, sensors' missing returns at one spot), exactly
    // or to float rounding, would give zero distances to eq. 1's weights and eq. 5's density: one
    // point of each group stands for all of it; the others map to its output point.
    const std::size_t before_merge = used.size();
    const std::vector<std::pair<int, int>> merged =
        sortAndMergeCoincident(used, position, lo, hi, resolveThreads(params_.threads));
    if (!merged.empty() && used.size() <= static_cast<std::size_t>(params_.k_neighbors))
      return fail("only " + std::to_string(used.size()) + " distinct finite points (" + std::to_string(merged.size()) +
                  " more at the same places); the neighbourhood size K = " + std::to_string(params_.k_neighbors) +
                  " needs at least " + std::to_string(params_.k_neighbors + 1));
    const Eigen::Vector3d origin = 0.5 * (lo + hi);
    // Extreme extents (micrometre parts in metres, planets in millimetres) are brought into
    // float's comfortable range by a power of four, which scales every length exactly; the
    // method is scale-free, and results are given back in the input's units.
    const double extent = (hi - lo).maxCoeff();
    if (!(extent > 1e-30))
      return fail("the cloud's extent (" + std::to_string(extent) + ") is too small for float precision");
    const double scale = frameScale(extent);
    auto local = std::make_shared<LocalCloud>();
    local->resize(used.size());
    NormalList input_normals;
    if (params_.use_input_normals)
      input_normals.resize(used.size());
    for (std::size_t i = 0; i < used.size(); ++i)
    {
      const PointT& p = (*input_)[used[i]];
      (*local)[i].getVector3fMap() = ((Eigen::Vector3d(p.x, p.y, p.z) - origin) * scale).template cast<float>();
      if (params_.use_input_normals)
        input_normals[i] = detail::getNormal(p);
    }
    const double t_prep_s = std::chrono::duration<double>(Clock::now() - t_prep).count();

    // 2. The method.
    CoreOutput core;
    const Status status = simplifyLocal(local, params_.use_input_normals ? &input_normals : nullptr,
                                        params_, progress_, core);
    if (status != Status::Ok)
      return fail(core.error);

    // 3. Output: features (input order), then one representative per ball.
    const auto t_out = Clock::now();
    const std::size_t n_features = core.summary.feature_points;
    const std::size_t n_balls = core.cover.balls.size();
    output.resize(n_features + n_balls);
    result_.labels.reserve(n_features + n_balls);
    result_.source_index.reserve(n_features + n_balls);
    result_.ball_of_output.reserve(n_features + n_balls);
    result_.input_to_output.assign(input_->size(), -1);
    std::vector<std::int64_t> local_to_output(used.size(), -1);
    std::size_t o = 0;
    // Estimated normals are oriented towards the sensor origin, as PCL's NormalEstimation does.
    const Eigen::Vector3d viewpoint = (input_->sensor_origin_.template head<3>().template cast<double>() - origin) * scale;
    auto oriented = [&](const Eigen::Vector3f& n, const Eigen::Vector3d& at) -> Eigen::Vector3f {
      if (params_.use_input_normals)
        return n;
      return (viewpoint - at).dot(n.template cast<double>()) < 0.0 ? Eigen::Vector3f(-n) : n;
    };
    std::vector<std::size_t> feature_locals;
    feature_locals.reserve(n_features);
    for (std::size_t i = 0; i < used.size(); ++i)
      if (core.is_feature[i])
        feature_locals.push_back(i);
    std::sort(feature_locals.begin(), feature_locals.end(),
              [&](std::size_t a, std::size_t b) { return used[a] < used[b]; });  // input order
    for (const std::size_t i : feature_locals)
    {
      output[o] = (*input_)[used[i]];
      detail::setNormal(output[o], oriented(core.normals[i], (*local)[i].getVector3fMap().template cast<double>()));
      result_.labels.push_back(PointLabel::Feature);
      result_.source_index.push_back(used[i]);
      result_.ball_of_output.push_back(-1);
      local_to_output[i] = static_cast<std::int64_t>(o);
      ++o;
    }
    result_.balls.resize(n_balls);
    for (std::size_t b = 0; b < n_balls; ++b)
    {
      const CoverBall& cb = core.cover.balls[b];
      PointT& p = output[o];
      p = (*input_)[used[static_cast<std::size_t>(cb.attribute_source)]];
      const Eigen::Vector3d world = cb.representative / scale + origin;
      p.x = static_cast<float>(world.x());
      p.y = static_cast<float>(world.y());
      p.z = static_cast<float>(world.z());
      detail::setNormal(p, oriented(cb.normal, cb.representative));
      Ball& ball = result_.balls[b];
      ball.centre_index = used[static_cast<std::size_t>(cb.centre)];
      ball.centre = (*local)[cb.centre].getVector3fMap().template cast<double>() / scale + origin;
      ball.representative = world;
      ball.radius = cb.radius / scale;
      ball.tolerance = cb.tolerance;
      ball.error = cb.error;
      ball.replaced = cb.replaced;
      ball.used_centre = cb.used_centre;
      ball.output_index = o;
      result_.labels.push_back(PointLabel::Representative);
      result_.source_index.push_back(used[static_cast<std::size_t>(cb.attribute_source)]);
      result_.ball_of_output.push_back(static_cast<std::int64_t>(b));
      ++o;
    }
    for (std::size_t i = 0; i < used.size(); ++i)
    {
      const std::int64_t out_idx =
          core.is_feature[i] ? local_to_output[i]
                             : static_cast<std::int64_t>(result_.balls[static_cast<std::size_t>(core.cover.owner[i])].output_index);
      result_.input_to_output[static_cast<std::size_t>(used[i])] = out_idx;
    }
    for (const auto& [gone, kept] : merged)
      result_.input_to_output[static_cast<std::size_t>(gone)] = result_.input_to_output[static_cast<std::size_t>(kept)];
    output.width = static_cast<std::uint32_t>(output.size());
    output.height = 1;
    output.is_dense = true;

    result_.summary = core.summary;
    unscaleSummary(result_.summary, scale);
    result_.summary.input_points = indices_->size();
    result_.summary.finite_points = before_merge;
    result_.summary.merged_points = merged.size();
    result_.summary.timings.preparation = t_prep_s;
    result_.summary.timings.output = std::chrono::duration<double>(Clock::now() - t_out).count();
    result_.summary.timings.total = std::chrono::duration<double>(Clock::now() - t_start).count();
  }
  catch (const std::exception& e)
  {
    return fail(std::string("internal error: ") + e.what());
  }
}

}  // namespace pcl_ecs
