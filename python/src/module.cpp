// pcl_ecs._core: the C++ library for Python (nanobind). The Python-facing API is
// python/pcl_ecs/__init__.py; this module gives it the Parameters struct (every field, with the
// library's defaults and validate()), the run on numpy arrays through the same code as
// pcd_simplify (tools/common/cloud_simplify.cpp), the cloud readers and writers, and Cocone.
#include "common/cli.h"
#include "common/cloud_simplify.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/io/cloud_io.h>
#include <pcl_ecs/io/las_io.h>
#include <pcl_ecs/io/record_stream.h>
#include <pcl_ecs/parameter_table.h>
#include <pcl_ecs/parameters.h>
#include <pcl_ecs/stream/out_of_core.h>
#include <pcl_ecs/surface/cocone.h>
#include <pcl_ecs/version.h>

#include <pcl/console/print.h>

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>
#include <nanobind/stl/pair.h>

#include <cstring>
#include <optional>
#include <stdexcept>

namespace nb = nanobind;
using namespace nb::literals;
using pcl_ecs::Parameters;

namespace
{
template <typename T>
using Array = nb::ndarray<T, nb::numpy, nb::c_contig>;

/// A numpy array that owns `v` (moved, not copied).
template <typename T>
nb::ndarray<nb::numpy, T> owned(std::vector<T>&& v, std::initializer_list<std::size_t> shape)
{
  auto* heap = new std::vector<T>(std::move(v));
  nb::capsule owner(heap, [](void* p) noexcept { delete static_cast<std::vector<T>*>(p); });
  return nb::ndarray<nb::numpy, T>(heap->data(), shape, owner);
}

/// The PCL datatype of a numpy array's element type, or 0 for one PCL has not.
std::uint8_t pclType(const nb::dlpack::dtype& t)
{
  static const std::pair<nb::dlpack::dtype, std::uint8_t> types[] = {
      {nb::dtype<std::int8_t>(), pcl::PCLPointField::INT8},     {nb::dtype<std::uint8_t>(), pcl::PCLPointField::UINT8},
      {nb::dtype<std::int16_t>(), pcl::PCLPointField::INT16},   {nb::dtype<std::uint16_t>(), pcl::PCLPointField::UINT16},
      {nb::dtype<std::int32_t>(), pcl::PCLPointField::INT32},   {nb::dtype<std::uint32_t>(), pcl::PCLPointField::UINT32},
      {nb::dtype<std::int64_t>(), pcl::PCLPointField::INT64},   {nb::dtype<std::uint64_t>(), pcl::PCLPointField::UINT64},
      {nb::dtype<float>(), pcl::PCLPointField::FLOAT32},        {nb::dtype<double>(), pcl::PCLPointField::FLOAT64}};
  for (const auto& [dt, type] : types)
    if (dt == t)
      return type;
  return 0;
}

/// The records of a cloud with x y z (float32 or float64), and optionally normals (float32),
/// colours (uint8, 3 or 4 channels: rgb or rgba), intensity (float32) and any other fields (a dict
/// of name -> (N,) or (N, count) arrays of a numeric type, kept as that type), from numpy arrays.
pcl::PCLPointCloud2 cloudFrom(nb::ndarray<nb::c_contig, nb::device::cpu> points, nb::object normals,
                              nb::object colors, nb::object intensity, nb::object fields = nb::none())
{
  if (points.ndim() != 2 || points.shape(1) != 3)
    throw std::invalid_argument("points must be an (N, 3) array");
  const bool dbl = points.dtype() == nb::dtype<double>();
  if (!dbl && points.dtype() != nb::dtype<float>())
    throw std::invalid_argument("points must be float32 or float64");
  const std::size_t n = points.shape(0);
  if (n > 0xFFFFFFFFull)
    throw std::invalid_argument("more points than a cloud holds (2^32 - 1)");
  pcl::PCLPointCloud2 c;
  for (const char* a : {"x", "y", "z"})
    pcl_ecs::io::appendField(c, a, dbl ? pcl::PCLPointField::FLOAT64 : pcl::PCLPointField::FLOAT32);
  std::optional<Array<const float>> nrm, inten;
  std::optional<Array<const std::uint8_t>> col;
  if (!normals.is_none())
  {
    nrm = nb::cast<Array<const float>>(normals);
    if (nrm->ndim() != 2 || nrm->shape(0) != n || nrm->shape(1) != 3)
      throw std::invalid_argument("normals must be an (N, 3) float32 array, N the number of points");
    for (const char* a : {"normal_x", "normal_y", "normal_z"})
      pcl_ecs::io::appendField(c, a, pcl::PCLPointField::FLOAT32);
  }
  if (!colors.is_none())
  {
    col = nb::cast<Array<const std::uint8_t>>(colors);
    if (col->ndim() != 2 || col->shape(0) != n || (col->shape(1) != 3 && col->shape(1) != 4))
      throw std::invalid_argument("colors must be an (N, 3) or (N, 4) uint8 array, N the number of points");
    pcl_ecs::io::appendField(c, col->shape(1) == 4 ? "rgba" : "rgb", col->shape(1) == 4 ? pcl::PCLPointField::UINT32 : pcl::PCLPointField::FLOAT32);
  }
  if (!intensity.is_none())
  {
    inten = nb::cast<Array<const float>>(intensity);
    if (inten->ndim() != 1 || inten->shape(0) != n)
      throw std::invalid_argument("intensity must be an (N,) float32 array, N the number of points");
    pcl_ecs::io::appendField(c, "intensity", pcl::PCLPointField::FLOAT32);
  }
  struct Extra
  {
    nb::ndarray<nb::c_contig, nb::device::cpu> array;
    std::uint32_t offset;
    std::size_t bytes;  // a point's
  };
  std::vector<Extra> extra;
  if (!fields.is_none())
  {
    for (auto [key, value] : nb::cast<nb::dict>(fields))
    {
      const std::string name = nb::cast<std::string>(key);
      nb::ndarray<nb::c_contig, nb::device::cpu> a;
      const bool numeric = nb::try_cast(value, a);
      const std::uint8_t type = numeric ? pclType(a.dtype()) : 0;
      if (name.empty() || name.find_first_of(" \t\n\r") != std::string::npos)
        throw std::invalid_argument("fields: a field name must be a word without spaces, not '" + name + "'");
      for (const pcl::PCLPointField& f : c.fields)
        if (f.name == name)
          throw std::invalid_argument("fields: '" + name + "' is given twice (it is one of the points' own fields)");
      if (type == 0)
        throw std::invalid_argument("fields: '" + name + "' must hold integers or floats of 8 to 64 bits");
      if ((a.ndim() != 1 && a.ndim() != 2) || a.shape(0) != n || (a.ndim() == 2 && a.shape(1) == 0))
        throw std::invalid_argument("fields: '" + name + "' must be an (N,) or (N, count) array, N the number of points");
      const std::uint32_t count = a.ndim() == 2 ? static_cast<std::uint32_t>(a.shape(1)) : 1u;
      const std::uint32_t offset = pcl_ecs::io::appendField(c, name, type, count);
      extra.push_back({a, offset, a.itemsize() * count});
    }
  }
  c.width = static_cast<std::uint32_t>(n);
  c.height = 1;
  c.row_step = c.point_step * c.width;
  c.data.resize(n * c.point_step);
  const std::size_t xyz_bytes = dbl ? 24 : 12;
  const auto* src = static_cast<const std::uint8_t*>(points.data());
  for (std::size_t i = 0; i < n; ++i)
  {
    std::uint8_t* rec = c.data.data() + i * c.point_step;
    std::memcpy(rec, src + i * xyz_bytes, xyz_bytes);
    std::size_t at = xyz_bytes;
    if (nrm)
    {
      std::memcpy(rec + at, nrm->data() + 3 * i, 12);
      at += 12;
    }
    if (col)
    {
      const std::uint8_t* k = col->data() + col->shape(1) * i;
      const std::uint32_t a = col->shape(1) == 4 ? k[3] : 255u;
      const std::uint32_t packed = (a << 24) | (std::uint32_t{k[0]} << 16) | (std::uint32_t{k[1]} << 8) | k[2];
      std::memcpy(rec + at, &packed, 4);
      at += 4;
    }
    if (inten)
      std::memcpy(rec + at, inten->data() + i, 4);
    for (const Extra& e : extra)
      std::memcpy(rec + e.offset, static_cast<const std::uint8_t*>(e.array.data()) + i * e.bytes, e.bytes);
  }
  c.is_dense = false;
  return c;
}

double coordinate(const pcl::PCLPointCloud2& c, std::size_t i, int axis)
{
  const pcl::PCLPointField& f = c.fields[static_cast<std::size_t>(axis)];
  const std::uint8_t* p = c.data.data() + i * c.point_step + f.offset;
  if (f.datatype == pcl::PCLPointField::FLOAT64)
  {
    double v;
    std::memcpy(&v, p, 8);
    return v;
  }
  float v;
  std::memcpy(&v, p, 4);
  return v;
}

nb::dict simplify(nb::ndarray<nb::c_contig, nb::device::cpu> points, nb::object normals, nb::object colors,
                  nb::object intensity, const Parameters& params, double target_ratio)
{
  const std::string bad = pcl_ecs::validate(params);
  if (!bad.empty())
    throw nb::value_error(bad.c_str());
  if (!(target_ratio >= 0.0 && target_ratio <= 1.0))
    throw nb::value_error("target_ratio must be in (0, 1]");
  if (target_ratio > 0.0 && params.target_size > 0)
    throw nb::value_error("target_size and target_ratio exclude each other");
  if (params.use_input_normals && normals.is_none())
    throw nb::value_error("use_input_normals needs normals");
  const pcl::PCLPointCloud2 cloud = cloudFrom(points, normals, colors, intensity);
  pcl_ecs::tools::CloudRunOptions options;
  options.target_ratio = target_ratio;
  pcl_ecs::tools::CloudRun run;
  {
    nb::gil_scoped_release release;
    run = pcl_ecs::tools::simplifyCloud(cloud, params, options);
  }
  if (!run.result.error.empty())
    throw nb::value_error(run.result.error.c_str());
  const pcl_ecs::Result& r = run.result;
  const std::size_t m = r.labels.size();
  std::vector<double> xyz(3 * m);
  for (std::size_t i = 0; i < m; ++i)
    for (int a = 0; a < 3; ++a)
      xyz[3 * i + a] = coordinate(run.output, i, a);
  std::vector<std::uint8_t> labels(m);
  for (std::size_t i = 0; i < m; ++i)
    labels[i] = static_cast<std::uint8_t>(r.labels[i]);
  std::vector<double> centre(3 * r.balls.size()), radius(r.balls.size()), tolerance(r.balls.size()),
      error(r.balls.size());
  std::vector<std::int64_t> replaced(r.balls.size()), centre_index(r.balls.size());
  for (std::size_t b = 0; b < r.balls.size(); ++b)
  {
    for (int a = 0; a < 3; ++a)
      centre[3 * b + a] = r.balls[b].centre[a];
    radius[b] = r.balls[b].radius;
    tolerance[b] = r.balls[b].tolerance;
    error[b] = r.balls[b].error;
    replaced[b] = static_cast<std::int64_t>(r.balls[b].replaced);
    centre_index[b] = r.balls[b].centre_index;
  }
  const std::size_t nb_balls = r.balls.size();
  const std::size_t n_in = r.input_to_output.size();
  nb::dict out;
  out["points"] = owned(std::move(xyz), {m, 3});
  out["labels"] = owned(std::move(labels), {m});
  out["source_index"] = owned(std::vector<std::int64_t>(r.source_index), {m});
  out["input_to_output"] = owned(std::vector<std::int64_t>(r.input_to_output), {n_in});
  out["ball_centre"] = owned(std::move(centre), {nb_balls, 3});
  out["ball_centre_index"] = owned(std::move(centre_index), {nb_balls});
  out["ball_radius"] = owned(std::move(radius), {nb_balls});
  out["ball_tolerance"] = owned(std::move(tolerance), {nb_balls});
  out["ball_error"] = owned(std::move(error), {nb_balls});
  out["ball_replaced"] = owned(std::move(replaced), {nb_balls});
  out["point_radius"] = owned(pcl_ecs::pointRadii(r), {m});
  out["summary_json"] = pcl_ecs::tools::runStatsJson(r.summary, params, target_ratio).dump();
  return out;
}

/// Every field of a cloud file, by name: (N,) arrays, or (N, count) for a field of count > 1.
nb::dict readFile(const std::string& path)
{
  pcl::PCLPointCloud2 c;
  try
  {
    pcl_ecs::io::readCloud(path, c);
  }
  catch (const pcl_ecs::io::FileError& e)
  {
    throw std::runtime_error(e.what());
  }
  catch (const pcl_ecs::io::FormatError& e)
  {
    throw nb::value_error(e.what());
  }
  const std::size_t n = static_cast<std::size_t>(c.width) * c.height;
  nb::dict out;
  nb::module_ np = nb::module_::import_("numpy");
  static const std::pair<std::uint8_t, const char*> types[] = {
      {pcl::PCLPointField::INT8, "i1"},    {pcl::PCLPointField::UINT8, "u1"},   {pcl::PCLPointField::INT16, "<i2"},
      {pcl::PCLPointField::UINT16, "<u2"}, {pcl::PCLPointField::INT32, "<i4"},  {pcl::PCLPointField::UINT32, "<u4"},
      {pcl::PCLPointField::FLOAT32, "<f4"}, {pcl::PCLPointField::FLOAT64, "<f8"}, {pcl::PCLPointField::INT64, "<i8"},
      {pcl::PCLPointField::UINT64, "<u8"}};
  // One structured view of the records, each field a column of it (copied into its own array).
  nb::list names, formats, offsets;
  for (const pcl::PCLPointField& f : c.fields)
  {
    const char* t = nullptr;
    for (const auto& [dt, name] : types)
      if (dt == f.datatype)
        t = name;
    if (!t || f.count == 0 || f.name == "_")
      continue;
    names.append(f.name);
    formats.append(f.count == 1 ? std::string(t) : "(" + std::to_string(f.count) + ",)" + t);
    offsets.append(f.offset);
  }
  nb::dict spec;
  spec["names"] = names;
  spec["formats"] = formats;
  spec["offsets"] = offsets;
  spec["itemsize"] = c.point_step;
  nb::object dtype = np.attr("dtype")(spec);
  nb::object raw = np.attr("frombuffer")(nb::bytes(reinterpret_cast<const char*>(c.data.data()), c.data.size()), dtype, n);
  for (nb::handle name : names)
    out[name] = np.attr("ascontiguousarray")(raw[name]);
  return out;
}

void writeFile(const std::string& path, nb::ndarray<nb::c_contig, nb::device::cpu> points, nb::object normals,
               nb::object colors, nb::object intensity, nb::object fields)
{
  const pcl_ecs::io::Format format = pcl_ecs::io::formatFromPath(path);
  if (format == pcl_ecs::io::Format::Unknown || format == pcl_ecs::io::Format::Xyz)
    throw nb::value_error((path + ": the file name must end in .pcd, .ply, .las or .laz").c_str());
  const pcl::PCLPointCloud2 cloud = cloudFrom(points, normals, colors, intensity, fields);
  try
  {
    // LAS / LAZ: the names of `fields` that are no LAS dimension become extra dimensions.
    std::vector<pcl_ecs::io::ExtraDimension> dims;
    if ((format == pcl_ecs::io::Format::Las || format == pcl_ecs::io::Format::Laz) && !fields.is_none())
      for (auto [key, value] : nb::cast<nb::dict>(fields))
        if (const std::string name = nb::cast<std::string>(key); !pcl_ecs::io::isLasFieldName(name))
          dims.push_back({name, ""});
    std::optional<pcl_ecs::io::LasInfo> las;
    if (!dims.empty())
    {
      las = pcl_ecs::io::lasInfoFor(cloud, nullptr);
      pcl_ecs::io::addLasExtraDimensions(*las, cloud.fields, dims);
    }
    pcl_ecs::io::AtomicOutput out(path);
    pcl_ecs::io::writeCloud(out.tempPath(), format, cloud, pcl_ecs::io::Encoding::Binary, las ? &*las : nullptr);
    out.commit();
  }
  catch (const pcl_ecs::io::FileError& e)
  {
    throw std::runtime_error(e.what());
  }
  catch (const pcl_ecs::io::FormatError& e)
  {
    throw nb::value_error(e.what());
  }
}

std::pair<nb::ndarray<nb::numpy, double>, nb::ndarray<nb::numpy, std::int64_t>> reconstruct(Array<const double> points,
                                                                                             nb::object radius,
                                                                                             nb::object scan,
                                                                                             nb::object scan_to_point)
{
  if (points.ndim() != 2 || points.shape(1) != 3)
    throw nb::value_error("points must be an (N, 3) float64 array");
  const std::size_t n = points.shape(0);
  std::vector<Eigen::Vector3d> pts(n);
  for (std::size_t i = 0; i < n; ++i)
    pts[i] = Eigen::Vector3d(points.data()[3 * i], points.data()[3 * i + 1], points.data()[3 * i + 2]);
  std::vector<double> sample_radius;
  if (!radius.is_none())
  {
    const auto r = nb::cast<Array<const double>>(radius);
    if (r.ndim() != 1 || r.shape(0) != n)
      throw nb::value_error("radius must be an (N,) float64 array, N the number of points");
    sample_radius.assign(r.data(), r.data() + n);
  }
  pcl_ecs::surface::ScanSupport support;
  pcl_ecs::surface::CoconeParameters params;
  if (!scan.is_none())
  {
    const auto sc = nb::cast<Array<const double>>(scan);
    if (sc.ndim() != 2 || sc.shape(1) != 3)
      throw nb::value_error("scan must be an (M, 3) float64 array");
    const std::size_t m = sc.shape(0);
    support.points.resize(m);
    for (std::size_t i = 0; i < m; ++i)
      support.points[i] = Eigen::Vector3d(sc.data()[3 * i], sc.data()[3 * i + 1], sc.data()[3 * i + 2]).cast<float>();
    if (!scan_to_point.is_none())
    {
      const auto o = nb::cast<Array<const std::int64_t>>(scan_to_point);
      if (o.ndim() != 1 || o.shape(0) != m)
        throw nb::value_error("scan_to_point must be an (M,) int64 array, M the number of scan points");
      support.sample_of.assign(o.data(), o.data() + m);
    }
    params.open_tunnels = true;
  }
  else if (!scan_to_point.is_none())
    throw nb::value_error("scan_to_point is read with scan only");
  pcl_ecs::surface::CoconeResult r;
  {
    nb::gil_scoped_release release;
    r = pcl_ecs::surface::coconeReconstruct(pts, params, sample_radius, support);
  }
  if (!r.ok())
    throw nb::value_error(r.error.c_str());
  std::vector<double> v(3 * n);
  for (std::size_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a)
      v[3 * i + a] = pts[i][a];
  std::vector<std::int64_t> t(3 * r.triangles.size());
  for (std::size_t k = 0; k < r.triangles.size(); ++k)
    for (int a = 0; a < 3; ++a)
      t[3 * k + a] = r.triangles[k][a];
  const std::size_t nt = r.triangles.size();
  return {owned(std::move(v), {n, 3}), owned(std::move(t), {nt, 3})};
}
/// Runs `fn` without the GIL, turning the library's errors into Python's: a bad input or a limit
/// that cannot be kept is ValueError, anything else (a file that cannot be read or written)
/// RuntimeError.
template <typename F>
auto translated(F&& fn) -> decltype(fn())
{
  try
  {
    nb::gil_scoped_release release;
    return fn();
  }
  catch (const pcl_ecs::io::FormatError& e)
  {
    throw nb::value_error(e.what());
  }
  catch (const pcl_ecs::stream::LimitError& e)
  {
    throw nb::value_error(e.what());
  }
}

nb::dict streamSummary(const pcl_ecs::stream::StreamSummary& s)
{
  nb::dict counts;
  counts["input_points"] = s.input_points;
  counts["finite_points"] = s.finite_points;
  counts["merged_points"] = s.merged_points;
  counts["feature_points"] = s.feature_points;
  counts["balls"] = s.balls;
  counts["gap_points"] = s.gap_points;
  counts["output_points"] = s.output_points;
  nb::dict out;
  out["counts"] = counts;
  out["max_error"] = s.max_error;
  out["tiles"] = s.tiles.size();
  out["bbox_diagonal"] = s.bbox_diagonal;
  out["feature_threshold"] = s.feature_threshold;
  return out;
}
}  // namespace

NB_MODULE(_core, m)
{
  m.doc() = "pcl_ecs: feature-preserving, error-controlled point cloud simplification (C++ core)";
  m.attr("__version__") = PCL_ECS_VERSION_STRING;
  m.attr("laz_supported") = pcl_ecs::io::lazSupported();
  // Errors reach Python as exceptions carrying the library's message; PCL's console would print
  // each one to stderr as well (the command-line tools silence it the same way).
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  nb::class_<Parameters>(m, "Parameters", "Every parameter of the method, with the C++ library's defaults")
      .def(nb::init<>())
      .def_rw("error_threshold", &Parameters::error_threshold)
      .def_rw("error_threshold_abs", &Parameters::error_threshold_abs)
      .def_rw("feature_factor", &Parameters::feature_factor)
      .def_rw("k_neighbors", &Parameters::k_neighbors)
      .def_prop_rw(
          "error_form", [](const Parameters& p) { return std::string(pcl_ecs::toString(p.error_form)); },
          [](Parameters& p, const std::string& s) {
            if (!pcl_ecs::parseErrorForm(s, p.error_form))
              throw nb::value_error(("error_form must be \"normalized\" or \"paper\", not \"" + s + "\"").c_str());
          })
      .def_rw("adaptive", &Parameters::adaptive)
      .def_rw("adaptive_factor", &Parameters::adaptive_factor)
      .def_rw("radius_cap_factor", &Parameters::radius_cap_factor)
      .def_rw("target_radius_cap", &Parameters::target_radius_cap)
      .def_rw("max_representative_offset", &Parameters::max_representative_offset)
      .def_rw("representative_cutoff", &Parameters::representative_cutoff)
      .def_rw("max_roughness", &Parameters::max_roughness)
      .def_rw("representative_fit", &Parameters::representative_fit)
      .def_rw("relax_representatives", &Parameters::relax_representatives)
      .def_rw("feature_spacing", &Parameters::feature_spacing)
      .def_rw("max_gap_factor", &Parameters::max_gap_factor)
      .def_rw("target_gap_factor", &Parameters::target_gap_factor)
      .def_prop_rw(
          "max_deviation",
          [](const Parameters& p) -> nb::object {
            // A number in the input's units, or "P%" of L: the same two forms as --max-deviation.
            if (p.max_deviation_of_L > 0.0)
              return nb::str(pcl_ecs::parameterText(*pcl_ecs::findParameter("max-deviation"), p).c_str());
            return nb::float_(p.max_deviation);
          },
          [](Parameters& p, nb::handle value) {
            std::string text;
            if (nb::isinstance<nb::str>(value))
              text = nb::cast<std::string>(value);
            else if (nb::isinstance<nb::float_>(value) || nb::isinstance<nb::int_>(value))
              text = nb::cast<std::string>(nb::str(value));
            else
              throw nb::type_error("max_deviation must be a number (input units) or a string \"P%\"");
            const std::string why = pcl_ecs::setParameter(*pcl_ecs::findParameter("max-deviation"), text, p);
            if (!why.empty())
              throw nb::value_error(("max_deviation: " + why).c_str());
          })
      .def_rw("report_deviation", &Parameters::report_deviation)
      .def_rw("seed", &Parameters::seed)
      .def_rw("use_input_normals", &Parameters::use_input_normals)
      .def_rw("threads", &Parameters::threads)
      .def_rw("target_size", &Parameters::target_size)
      .def("validate", [](const Parameters& p) { return pcl_ecs::validate(p); },
           "The reason the parameters are invalid, or an empty string");
  m.def(
      "_parameter_table",
      [] {
        nb::list rows;
        for (const pcl_ecs::ParameterInfo& info : pcl_ecs::parameterTable())
        {
          nb::dict row;
          row["name"] = info.name;
          row["field"] = info.field;
          row["metavar"] = info.metavar;
          row["range"] = info.range;
          row["help"] = info.help;
          rows.append(row);
        }
        return rows;
      },
      "Every parameter: its one spelling (the flag without dashes, the --stats JSON key), its field, its help");
  m.def(
      "_set_parameter",
      [](Parameters& p, const std::string& name, const std::string& text) {
        const pcl_ecs::ParameterInfo* info = pcl_ecs::findParameter(name);
        if (!info)
          throw nb::value_error(("no parameter '" + name + "'").c_str());
        const std::string why = pcl_ecs::setParameter(*info, text, p);
        if (!why.empty())
          throw nb::value_error(("--" + name + ": " + why).c_str());
      },
      "p"_a, "name"_a, "text"_a, "Set a parameter from its flag's text (as pcd_simplify reads it)");
  m.def("_simplify", &simplify, "points"_a, "normals"_a.none(), "colors"_a.none(), "intensity"_a.none(),
        "params"_a, "target_ratio"_a);
  m.def("_read", &readFile, "path"_a);
  m.def("_write", &writeFile, "path"_a, "points"_a, "normals"_a.none(), "colors"_a.none(), "intensity"_a.none(),
        "fields"_a.none());
  m.def("_reconstruct", &reconstruct, "points"_a, "radius"_a.none(), "scan"_a.none(), "scan_to_point"_a.none());
  using pcl_ecs::stream::TiledRun;
  nb::class_<TiledRun>(m, "_TiledRun")
      .def("__init__",
           [](TiledRun* self, const std::vector<std::string>& inputs, const std::string& output,
              const Parameters& params, std::uint64_t memory_limit, const std::string& scratch,
              std::uint64_t tile_points, bool keep_scratch) {
             pcl_ecs::stream::StreamOptions o;
             o.memory_limit = memory_limit;
             o.scratch_dir = scratch;
             o.max_tile_points = tile_points;
             o.keep_scratch = keep_scratch;
             new (self) TiledRun(inputs, output, params, o);
           },
           "inputs"_a, "output"_a, "params"_a, "memory_limit"_a, "scratch"_a, "tile_points"_a, "keep_scratch"_a)
      .def("prepare", [](TiledRun& r, bool plan) { return translated([&] { return r.prepare(plan); }); }, "plan"_a)
      .def("colours", [](TiledRun& r) { return translated([&] { return r.colours(); }); })
      .def("run_task",
           [](TiledRun& r, const std::string& stage, int tile) {
             if (stage.size() != 1)
               throw nb::value_error("stage must be one of A, B, C, D");
             return translated([&] { return r.runTask(stage[0], tile); });
           },
           "stage"_a, "tile"_a)
      .def("finish", [](TiledRun& r) { return streamSummary(translated([&] { return r.finish(); })); });
  m.def("_keep_freed_memory", &pcl_ecs::tools::keepFreedMemory,
        "Keep freed memory in this process for the next task instead of faulting it in again "
        "(what pcd_simplify does; for a process that runs the out-of-core tasks)");
  m.def("_record_inputs", [](const std::vector<std::string>& args) {
    try
    {
      return pcl_ecs::io::recordInputs(args);
    }
    catch (const pcl_ecs::io::FileError& e)
    {
      throw nb::value_error(e.what());
    }
  });
  m.def("_parse_byte_size", [](const std::string& text) {
    std::uint64_t bytes = 0;
    if (!pcl_ecs::stream::parseByteSize(text, bytes))
      throw nb::value_error(("not a size: '" + text + "' (e.g. 512M, 2G)").c_str());
    return bytes;
  });
}
