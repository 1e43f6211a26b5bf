#include "cloud_simplify.h"

#include <pcl_ecs/parameter_table.h>

#include <pcl_ecs/spatial_order.h>

#include <pcl_ecs/feature_aware_cover_simplify.h>
#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/io/pcd_stream.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <memory>

namespace pcl_ecs
{
namespace tools
{

namespace
{
template <typename PointT>
Result runFilter(const pcl::PCLPointCloud2& input, const Eigen::Vector3d& shift, const Parameters& params,
                 const ProgressCallback& progress)
{
  auto cloud = std::make_shared<pcl::PointCloud<PointT>>();
  io::fromCloud(input, *cloud, shift);
  cloud->sensor_origin_ = Eigen::Vector4f(static_cast<float>(-shift.x()), static_cast<float>(-shift.y()),
                                          static_cast<float>(-shift.z()), 0.0f);
  FeatureAwareCoverSimplify<PointT> filter;
  filter.setParameters(params);
  filter.setProgressCallback(progress);
  filter.setInputCloud(cloud);
  pcl::PointCloud<PointT> out;
  filter.filter(out);
  return filter.getResult();
}

/// Float coordinates go to the filter unshifted (it works in its own local frame: the same result,
/// bit for bit, as the library on the same points); wider ones are brought near zero in double
/// first, so that float keeps them precise.
Eigen::Vector3d coordinateShift(const pcl::PCLPointCloud2& cloud)
{
  for (const char* axis : {"x", "y", "z"})
  {
    const int f = io::fieldIndex(cloud.fields, axis);
    if (f >= 0 && cloud.fields[static_cast<std::size_t>(f)].datatype != pcl::PCLPointField::FLOAT32)
      return io::boundingBoxCentre(cloud);
  }
  return Eigen::Vector3d::Zero();
}

}  // namespace

std::size_t distinctFinitePoints(const pcl::PCLPointCloud2& cloud)
{
  // The points as the filter will see them, merged by the filter's own rule (spatial_order.h),
  // so that "distinct" means what its merge means.
  pcl::PointCloud<pcl::PointXYZ> xyz;
  io::fromCloud(cloud, xyz, coordinateShift(cloud));
  std::vector<int> ids;
  ids.reserve(xyz.size());
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for (std::size_t i = 0; i < xyz.size(); ++i)
    if (std::isfinite(xyz[i].x) && std::isfinite(xyz[i].y) && std::isfinite(xyz[i].z))
    {
      ids.push_back(static_cast<int>(i));
      lo = lo.cwiseMin(xyz[i].getVector3fMap().cast<double>());
      hi = hi.cwiseMax(xyz[i].getVector3fMap().cast<double>());
    }
  if (ids.size() < 2)
    return ids.size();
  sortAndMergeCoincident(ids, [&](int i) { return Eigen::Vector3d(xyz[i].getVector3fMap().cast<double>()); }, lo, hi);
  return ids.size();
}

namespace
{
/// Appends to every record of `out` a field `name` of one `datatype` value (io::appendField), whose
/// bytes for point i `write(i, dst)` fills.
template <typename Write>
void appendPerPoint(pcl::PCLPointCloud2& out, const char* name, std::uint8_t datatype, Write write)
{
  const std::uint32_t old_step = out.point_step;
  const std::size_t m = static_cast<std::size_t>(out.width) * out.height;
  io::appendField(out, name, datatype);
  const std::uint32_t step = out.point_step;
  std::vector<std::uint8_t> data(m * step);
  for (std::size_t i = 0; i < m; ++i)
  {
    std::memcpy(data.data() + i * step, out.data.data() + i * old_step, old_step);
    write(i, data.data() + i * step + old_step);
  }
  out.row_step = step * out.width;
  out.data = std::move(data);
}
}  // namespace

CloudRun simplifyCloud(const pcl::PCLPointCloud2& input, const Parameters& given, const CloudRunOptions& options)
{
  CloudRun run;
  const auto& fields = input.fields;
  const int fx = io::fieldIndex(fields, "x"), fy = io::fieldIndex(fields, "y"), fz = io::fieldIndex(fields, "z");
  if (fx < 0 || fy < 0 || fz < 0)
  {
    run.result.error = "the cloud has no x, y and z fields";
    return run;
  }
  Parameters params = given;
  if (options.target_ratio > 0.0)
    params.target_size = std::max<std::size_t>(
        1, static_cast<std::size_t>(std::llround(options.target_ratio * static_cast<double>(distinctFinitePoints(input)))));
  const Eigen::Vector3d shift = coordinateShift(input);
  if (params.use_input_normals)
  {
    if (io::fieldIndex(fields, "normal_x") < 0 || io::fieldIndex(fields, "normal_y") < 0 ||
        io::fieldIndex(fields, "normal_z") < 0)
    {
      run.result.error = "use_input_normals is set but the cloud has no normal_x, normal_y and normal_z fields";
      return run;
    }
    run.result = runFilter<pcl::PointNormal>(input, shift, params, options.progress);
  }
  else
    run.result = runFilter<pcl::PointXYZ>(input, shift, params, options.progress);
  Result& r = run.result;
  if (!r.error.empty())
    return run;
  for (Ball& b : r.balls)
  {
    b.centre += shift;
    b.representative += shift;
  }

  // The output: the source records, packed, representatives moved to their optimised point.
  pcl::PCLPointCloud2& out = run.output;
  out.header = input.header;
  // A field this run adds (ecs_label, ecs_radius) that the input has already (a LAS extra dimension
  // or a PCD field of an earlier run) is not copied: the new values replace it.
  std::vector<pcl::PCLPointField> kept;
  for (const pcl::PCLPointField& f : fields)
    if (!(options.labels && f.name == "ecs_label") && !(options.radii && f.name == "ecs_radius"))
      kept.push_back(f);
  out.point_step = io::packedFields(kept, out.fields);
  const std::size_t m = r.labels.size();
  out.width = static_cast<std::uint32_t>(m);
  out.height = 1;
  out.row_step = out.point_step * out.width;
  out.is_dense = true;
  out.data.assign(m * out.point_step, 0);
  io::copyRecords(input.data.data(), input.point_step, fields, r.source_index, out.data.data(), out.point_step,
                  out.fields);
  const pcl::PCLPointField* axis[3] = {&out.fields[static_cast<std::size_t>(io::fieldIndex(out.fields, "x"))],
                                       &out.fields[static_cast<std::size_t>(io::fieldIndex(out.fields, "y"))],
                                       &out.fields[static_cast<std::size_t>(io::fieldIndex(out.fields, "z"))]};
  for (std::size_t i = 0; i < m; ++i)
  {
    if (r.labels[i] != PointLabel::Representative)
      continue;
    const Ball& ball = r.balls[static_cast<std::size_t>(r.ball_of_output[i])];
    if (ball.isOwnPoint())
      continue;  // its record, copied whole: the input's coordinates in the input's own type
    const Eigen::Vector3d& v = ball.representative;
    std::uint8_t* rec = out.data.data() + i * out.point_step;
    for (int a = 0; a < 3; ++a)
      io::storeFieldValue(v[a], axis[a]->datatype, rec + axis[a]->offset);  // in the input's own type
  }
  if (options.features)
  {
    pcl::PCLPointCloud2& f = run.features;
    f.header = out.header;
    f.fields = out.fields;
    f.point_step = out.point_step;
    f.height = 1;
    f.is_dense = true;
    for (std::size_t i = 0; i < m; ++i)
      if (r.labels[i] == PointLabel::Feature)
        f.data.insert(f.data.end(), out.data.begin() + static_cast<std::ptrdiff_t>(i * out.point_step),
                      out.data.begin() + static_cast<std::ptrdiff_t>((i + 1) * out.point_step));
    f.width = static_cast<std::uint32_t>(f.data.size() / std::max<std::uint32_t>(1, f.point_step));
    f.row_step = f.point_step * f.width;
  }
  if (options.labels)
    appendPerPoint(out, "ecs_label", pcl::PCLPointField::UINT8,
                   [&](std::size_t i, std::uint8_t* dst) { *dst = static_cast<std::uint8_t>(r.labels[i]); });
  if (options.radii)
  {
    const std::vector<double> radius = pointRadii(r);
    appendPerPoint(out, "ecs_radius", pcl::PCLPointField::FLOAT32, [&](std::size_t i, std::uint8_t* dst) {
      const auto v = static_cast<float>(radius[i]);
      std::memcpy(dst, &v, sizeof v);
    });
  }
  return run;
}

nlohmann::json parametersJson(const Parameters& p)
{
  nlohmann::json j = nlohmann::json::object();
  for (const ParameterInfo& info : parameterTable())
    std::visit(
        [&](auto member) {
          using T = std::decay_t<decltype(p.*member)>;
          if constexpr (std::is_same<T, bool>::value)
            j[info.name] = p.*member == info.switch_value;  // the switch is given
          else if constexpr (std::is_same<T, ErrorForm>::value)
            j[info.name] = toString(p.*member);
          else if constexpr (std::is_same<T, double>::value)
          {
            // A number, or the row's text when that is not one ("0.1%" of L for max-deviation).
            const std::string text = parameterText(info, p);
            double number = 0.0;
            if (parseReal(text, number).empty())
              j[info.name] = p.*member;
            else
              j[info.name] = text;
          }
          else
            j[info.name] = p.*member;
        },
        info.member);
  return j;
}

nlohmann::json runStatsJson(const Summary& s, const Parameters& p, double target_ratio)
{
  const StageTimings& t = s.timings;
  nlohmann::json j;
  // Every parameter under its one spelling (parameter_table.h), and what a target-size run used:
  // with --terr, --radius-cap and --max-gap at these "-used" values a plain run gives this output.
  j["parameters"] = parametersJson(p);
  j["parameters"]["terr-used"] = s.error_threshold;
  j["parameters"]["radius-cap-used"] = s.radius_cap_factor;
  j["parameters"]["feature-spacing-used"] = s.feature_spacing;
  j["parameters"]["max-gap-used"] = s.radius_cap_factor > 0.0 && s.neighborhood_radius > 0.0
                                        ? s.max_gap / (s.radius_cap_factor * s.neighborhood_radius)
                                        : p.max_gap_factor;
  j["parameters"]["target-ratio"] = target_ratio;
  j["counts"] = {{"input_points", s.input_points},
                 {"finite_points", s.finite_points},
                 {"feature_points", s.feature_points},
                 {"thinned_features", s.thinned_features},
                 {"balls", s.balls},
                 {"output_points", s.output_points},
                 {"centre_fallbacks", s.centre_fallbacks},
                 {"rough_balls", s.rough_balls},
                 {"merged_points", s.merged_points},
                 {"gap_points", s.gap_points},
                 {"size_points", s.size_points},
                 {"target_iterations", s.target_iterations},
                 {"cover_passes", s.cover_passes},
                 {"estimated_trials", s.estimated_trials}};
  if (s.target_size > 0)
    j["target"] = {{"size", s.target_size}, {"reached", s.target_reached}, {"closest_size", s.output_points}};
  j["target_reached"] = s.target_reached;
  j["geometry"] = {{"bbox_diagonal", s.bbox_diagonal},
                   {"feature_threshold", s.feature_threshold},
                   {"mean_spacing", s.mean_spacing},
                   {"neighborhood_radius", s.neighborhood_radius},
                   {"mean_abs_curvature", s.mean_abs_curvature},
                   {"max_error", s.max_error},
                   {"max_error_units", s.max_error * s.bbox_diagonal}};
  // Every input point's distance to the output's surface, input units (null when not measured).
  j["deviation"] = s.deviation_measured ? nlohmann::json{{"max", s.deviation_max},
                                                         {"p99", s.deviation_p99},
                                                         {"rms", s.deviation_rms},
                                                         {"bound", s.max_deviation},
                                                         {"added_points", s.deviation_points}}
                                        : nlohmann::json(nullptr);
  j["timings_s"] = {{"preparation", t.preparation}, {"neighbors", t.neighbors},
                    {"normals", t.normals},         {"weights", t.weights},
                    {"features", t.features},       {"density", t.density},
                    {"curvature", t.curvature},     {"cover", t.cover},
                    {"deviation", t.deviation},     {"output", t.output},
                    {"total", t.total}};
  return j;
}

}  // namespace tools
}  // namespace pcl_ecs
