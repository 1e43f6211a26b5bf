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
/// The finite points of the indices in the method's local frame (step 1 of applyFilter).
template <typename PointT>
struct LocalFrame
{
  std::vector<int> used;                   ///< local index -> input index (Hilbert order)
  std::vector<std::pair<int, int>> merged; ///< (merged input index, the input index standing for it)
  std::size_t finite = 0;                  ///< finite points before the merge
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  double scale = 1.0;                      ///< local = (world − origin) × scale
  LocalCloud::Ptr local;
  NormalList input_normals;                ///< with use_input_normals
};

/// Step 1: the finite points of `indices`, coincident ones merged, in Hilbert order, moved to a
/// local frame (double origin) for float precision. Returns why the cloud cannot be simplified
/// (empty when it can).
template <typename PointT>
std::string makeLocalFrame(const pcl::PointCloud<PointT>& input, const pcl::Indices& indices,
                           const Parameters& params, LocalFrame<PointT>& f)
{
  f.used.reserve(indices.size());
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const auto idx : indices)
  {
    const PointT& p = input[idx];
    // Checked whatever is_dense says: a cloud that claims to be dense may not be.
    if (!pcl::isXYZFinite(p))
      continue;
    if (params.use_input_normals && !getNormal(p).allFinite())
      continue;
    f.used.push_back(static_cast<int>(idx));
    const Eigen::Vector3d q(p.x, p.y, p.z);
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  f.finite = f.used.size();
  if (f.used.empty())
    return "the input has no finite points";
  if (lo == hi && f.used.size() > 1)
    return "all points are identical: there is no surface to simplify";
  // Store the points in Hilbert order: every neighbour query of every stage is then local.
  const auto position = [&](int idx) {
    const PointT& p = input[idx];
    return Eigen::Vector3d(p.x, p.y, p.z);
  };
  // Coincident points (merged scans, re-exports, sensors' missing returns at one spot), exactly
  // or to float rounding, would give zero distances to eq. 1's weights and eq. 5's density: one
  // point of each group stands for all of it; the others map to its output point.
  f.merged = sortAndMergeCoincident(f.used, position, lo, hi, resolveThreads(params.threads));
  if (!f.merged.empty() && f.used.size() <= static_cast<std::size_t>(params.k_neighbors))
    return "only " + std::to_string(f.used.size()) + " distinct finite points (" + std::to_string(f.merged.size()) +
           " more at the same places); the neighbourhood size K = " + std::to_string(params.k_neighbors) +
           " needs at least " + std::to_string(params.k_neighbors + 1);
  f.origin = 0.5 * (lo + hi);
  // Extreme extents (micrometre parts in metres, planets in millimetres) are brought into
  // float's comfortable range by a power of four, which scales every length exactly; the
  // method is scale-free, and results are given back in the input's units.
  const double extent = (hi - lo).maxCoeff();
  if (!(extent > 1e-30))
    return "the cloud's extent (" + std::to_string(extent) + ") is too small for float precision";
  f.scale = frameScale(extent);
  f.local = std::make_shared<LocalCloud>();
  f.local->resize(f.used.size());
  if (params.use_input_normals)
    f.input_normals.resize(f.used.size());
  for (std::size_t i = 0; i < f.used.size(); ++i)
  {
    const PointT& p = input[f.used[i]];
    (*f.local)[i].getVector3fMap() = ((Eigen::Vector3d(p.x, p.y, p.z) - f.origin) * f.scale).template cast<float>();
    if (params.use_input_normals)
      f.input_normals[i] = getNormal(p);
  }
  return {};
}

/// Step 3: the output cloud (features in input order, then one representative per ball) and the
/// result's per-point and per-ball records, in the input's frame.
template <typename PointT>
void assembleOutput(const pcl::PointCloud<PointT>& input, const LocalFrame<PointT>& f, const CoreOutput& core,
                    bool use_input_normals, pcl::PointCloud<PointT>& output, Result& result)
{
  const LocalCloud& local = *f.local;
  const std::vector<int>& used = f.used;
  const std::size_t n_features = core.summary.feature_points;
  const std::size_t n_balls = core.cover.balls.size();
  output.resize(n_features + n_balls);
  result.labels.reserve(n_features + n_balls);
  result.source_index.reserve(n_features + n_balls);
  result.ball_of_output.reserve(n_features + n_balls);
  result.input_to_output.assign(input.size(), -1);
  std::vector<std::int64_t> local_to_output(used.size(), -1);
  std::size_t o = 0;
  // Estimated normals are oriented towards the sensor origin, as PCL's NormalEstimation does.
  const Eigen::Vector3d viewpoint = (input.sensor_origin_.template head<3>().template cast<double>() - f.origin) * f.scale;
  auto oriented = [&](const Eigen::Vector3f& n, const Eigen::Vector3d& at) -> Eigen::Vector3f {
    return use_input_normals ? n : orientTowards(n, at, viewpoint);
  };
  std::vector<std::size_t> feature_locals;
  feature_locals.reserve(n_features);
  // A feature point the thinning left out (core.feature_kept_by) is stood for by a kept one.
  for (std::size_t i = 0; i < used.size(); ++i)
    if (core.is_feature[i] && core.keptFeature(i) == i)
      feature_locals.push_back(i);
  std::sort(feature_locals.begin(), feature_locals.end(),
            [&](std::size_t a, std::size_t b) { return used[a] < used[b]; });  // input order
  for (const std::size_t i : feature_locals)
  {
    output[o] = input[used[i]];
    setNormal(output[o], oriented(core.normals[i], local[i].getVector3fMap().template cast<double>()));
    result.labels.push_back(PointLabel::Feature);
    result.source_index.push_back(used[i]);
    result.ball_of_output.push_back(-1);
    local_to_output[i] = static_cast<std::int64_t>(o);
    ++o;
  }
  result.balls.resize(n_balls);
  for (std::size_t b = 0; b < n_balls; ++b)
  {
    const CoverBall& cb = core.cover.balls[b];
    PointT& p = output[o];
    p = input[used[static_cast<std::size_t>(cb.attribute_source)]];
    // A point made an output point of its own (isOwnPoint: its record is the one copied above)
    // keeps its input coordinates exactly, as the out-of-core run copies its record; the others
    // come back from the local frame.
    const Eigen::Vector3d world = isOwnPoint(cb) ? Eigen::Vector3d(p.getVector3fMap().template cast<double>())
                                            : Eigen::Vector3d(cb.representative / f.scale + f.origin);
    p.x = static_cast<float>(world.x());
    p.y = static_cast<float>(world.y());
    p.z = static_cast<float>(world.z());
    setNormal(p, oriented(cb.normal, cb.representative));
    Ball& ball = result.balls[b];
    ball.centre_index = used[static_cast<std::size_t>(cb.centre)];
    ball.centre = local[cb.centre].getVector3fMap().template cast<double>() / f.scale + f.origin;
    ball.representative = world;
    ball.radius = cb.radius / f.scale;
    ball.tolerance = cb.tolerance;
    ball.error = cb.error;
    ball.replaced = cb.replaced;
    ball.used_centre = cb.used_centre;
    ball.output_index = o;
    result.labels.push_back(PointLabel::Representative);
    result.source_index.push_back(used[static_cast<std::size_t>(cb.attribute_source)]);
    result.ball_of_output.push_back(static_cast<std::int64_t>(b));
    ++o;
  }
  for (std::size_t i = 0; i < used.size(); ++i)
  {
    // The ball that owns the point (a thinned-out feature point the gap bound made an output point
    // of its own has one), else the feature point standing for it.
    const int owner = core.cover.owner[i];
    const std::int64_t out_idx =
        owner >= 0 ? static_cast<std::int64_t>(result.balls[static_cast<std::size_t>(owner)].output_index)
                   : local_to_output[core.keptFeature(i)];
    result.input_to_output[static_cast<std::size_t>(used[i])] = out_idx;
  }
  for (const auto& [gone, kept] : f.merged)
    result.input_to_output[static_cast<std::size_t>(gone)] = result.input_to_output[static_cast<std::size_t>(kept)];
  output.width = static_cast<std::uint32_t>(output.size());
  output.height = 1;
  output.is_dense = true;
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
    // 1. Finite points of the indices, in a local frame.
    const auto t_prep = Clock::now();
    detail::LocalFrame<PointT> frame;
    why = detail::makeLocalFrame(*input_, *indices_, params_, frame);
    result_.summary.input_points = indices_->size();
    result_.summary.finite_points = frame.finite;
    if (!why.empty())
      return fail(why);
    const double t_prep_s = std::chrono::duration<double>(Clock::now() - t_prep).count();

    // 2. The method.
    CoreOutput core;
    Parameters local_params = params_;  // lengths in the local frame's units
    local_params.max_deviation *= frame.scale;
    local_params.error_threshold_abs *= frame.scale;
    const Status status = simplifyLocal(frame.local, params_.use_input_normals ? &frame.input_normals : nullptr,
                                        local_params, progress_, core);
    if (status != Status::Ok)
      return fail(core.error);

    // 3. The output.
    const auto t_out = Clock::now();
    detail::assembleOutput(*input_, frame, core, params_.use_input_normals, output, result_);
    result_.summary = core.summary;
    unscaleSummary(result_.summary, frame.scale);
    result_.summary.input_points = indices_->size();
    result_.summary.finite_points = frame.finite;
    result_.summary.merged_points = frame.merged.size();
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
