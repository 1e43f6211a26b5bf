#include <pcl_ecs/parameter_table.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>

namespace pcl_ecs
{

namespace
{
constexpr double kInf = std::numeric_limits<double>::infinity();

std::vector<ParameterInfo> makeTable()
{
  using P = Parameters;
  // name, field, symbol, member, metavar, switch value, min, max, min open, max open, 0 allowed,
  // range, help, changes the output
  return {
      {"terr", "error_threshold", "T_err", &P::error_threshold, "T", false, 0, 1, true, true, false, "in (0, 1)",
       "error bound T_err, a fraction of the bounding-box diagonal L; larger keeps fewer points", true},
      {"terr-abs", "error_threshold_abs", "", &P::error_threshold_abs, "D", false, 0, kInf, true, false, true,
       "0 (off) or > 0 (input units)",
       "T_err in the input's units instead of a fraction of L (it becomes D / L, which must be below 1); "
       "0 = use --terr",
       true},
      {"alpha", "feature_factor", "alpha", &P::feature_factor, "A", false, 0, kInf, true, true, false,
       "a finite number > 0", "feature factor α of eq. 4; larger keeps fewer feature points", true},
      {"k", "k_neighbors", "K", &P::k_neighbors, "K", false, 5, 200, false, false, false, "an integer in [5, 200]",
       "neighbourhood size", true},
      {"error-form", "error_form", "", &P::error_form, "F", false, 0, 0, false, false, false,
       "normalized or paper", "normalized (scale-free) or paper (the paper's literal eq. 14)", true},
      {"no-adapt", "adaptive", "", &P::adaptive, "", false, 0, 0, false, false, false, "true or false",
       "do not adapt T_err to local curvature and density (step 5)", true},
      {"adapt-factor", "adaptive_factor", "", &P::adaptive_factor, "F", false, 1, 100, false, false, false,
       "in [1, 100]", "adaptation factor of step 5", true},
      {"radius-cap", "radius_cap_factor", "", &P::radius_cap_factor, "C", false, 0, 1000, true, false, false,
       "in (0, 1000]", "largest ball radius, in mean neighbourhood radii", true},
      {"rep-offset", "max_representative_offset", "", &P::max_representative_offset, "F", false, 0, 1, true, false,
       false, "in (0, 1]",
       "the optimised point stands for its ball when within F × r of the centre, else the centre (the paper: 1)",
       true},
      {"rep-cutoff", "representative_cutoff", "", &P::representative_cutoff, "F", false, 0, 1, true, false, false,
       "in (0, 1]",
       "the optimised point moves from the centre only along the directions whose eigenvalue is above F × the "
       "largest of its quadric (E(r) uses 0.001)",
       true},
      {"max-roughness", "max_roughness", "", &P::max_roughness, "F", false, 0, 10, true, false, false, "in (0, 10]",
       "a ball whose points scatter about their planes by more than F × r (RMS) keeps its centre, an input "
       "point (2 = never)",
       true},
      {"no-rep-fit", "representative_fit", "", &P::representative_fit, "", false, 0, 0, false, false, false,
       "true or false",
       "keep the optimised point (the paper's method) instead of moving a smooth ball's representative onto the "
       "quadratic fitted to its points, and representing a ball no quadratic fits by its point nearest to it",
       true},
      {"no-relax", "relax_representatives", "", &P::relax_representatives, "", false, 0, 0, false, false, false,
       "true or false",
       "leave each representative where the cover put it instead of moving it, along its fitted surface, "
       "towards the centre of the points nearest to it (the paper's method)",
       true},
      {"max-gap", "max_gap_factor", "", &P::max_gap_factor, "G", false, 0, 100, true, false, true,
       "0 (off) or in (0, 100]",
       "no input point farther than G × the radius cap from the output: points left farther become output "
       "points; 0 = off (the paper's method)",
       true},
      {"target-gap", "target_gap_factor", "", &P::target_gap_factor, "G", false, 0, 100, true, false, true,
       "0 (off) or in (0, 100]", "the same with a target size, × the cap the target implies", true},
      {"feature-spacing", "feature_spacing", "", &P::feature_spacing, "F", false, 0, 1000, true, false, true,
       "0 (off) or in (0, 1000]",
       "feature points thinned along the edges to one per F mean neighbourhood radii; 0 = keep them all (the "
       "paper's method); a target size sets it itself",
       true},
      {"max-deviation", "max_deviation", "", &P::max_deviation, "D", false, 0, kInf, true, false, true,
       "0 (off), > 0 (input units) or a percentage of L in (0%, 100%]",
       "every input point ends within D of the output's surface (the plane of its 8 nearest output points, "
       "or its nearest output point when closer): points that would lie farther become output points; "
       "D in the input's units, or P% of the bounding box's diagonal; 0 = off; not with a target size",
       true},
      {"report-deviation", "report_deviation", "", &P::report_deviation, "", true, 0, 0, false, false, false,
       "true or false",
       "measure every input point's distance to the output's surface and report its max, p99 and RMS "
       "(always with --max-deviation; costs about a third of a plain run)",
       false},
      {"seed", "seed", "", &P::seed, "S", false, 0, kInf, false, true, false, "any integer >= 0",
       "seed of the centre order; same seed, same output", true},
      {"threads", "threads", "", &P::threads, "N", false, 0, 1024, false, false, false,
       "an integer in [0, 1024] (0 = all hardware threads)",
       "worker threads, 0 = all; the output does not depend on it", false},
      {"use-input-normals", "use_input_normals", "", &P::use_input_normals, "", true, 0, 0, false, false, false,
       "true or false", "use the input's normals instead of estimating them", true},
      {"target-size", "target_size", "", &P::target_size, "N", false, 1, kInf, false, true, true,
       "0 (off) or an integer >= 1", "aim at N output points (searches T_err; within 1% or the closest)", true},
      {"target-cap", "target_radius_cap", "", &P::target_radius_cap, "C", false, 0, 1000, true, false, true,
       "0 (off) or in (0, 1000]",
       "with a target size, the radius cap is C × the spacing the target implies instead of --radius-cap; "
       "0 = use --radius-cap",
       true},
  };
}

/// The shortest text (15 to 17 significant digits) that reads back as exactly `v`.
std::string formatNumber(double v)
{
  char buf[40];
  for (int digits = 15; digits <= 17; ++digits)
  {
    std::snprintf(buf, sizeof buf, "%.*g", digits, v);
    if (std::strtod(buf, nullptr) == v)
      break;
  }
  return buf;
}

/// The one row whose text has two forms (max_deviation, or max_deviation_of_L as "P%").
bool isMaxDeviation(const ParameterInfo& info)
{
  return std::holds_alternative<double Parameters::*>(info.member) &&
         std::get<double Parameters::*>(info.member) == &Parameters::max_deviation;
}

/// A number within the row's range (0 as well when the row allows it).
bool numberInRange(const ParameterInfo& info, double v)
{
  if (!std::isfinite(v))
    return false;
  if (info.zero_allowed && v == 0.0)
    return true;
  const bool above = info.min_open ? v > info.min : v >= info.min;
  const bool below = info.max == kInf || (info.max_open ? v < info.max : v <= info.max);
  return above && below;
}
}  // namespace

const std::vector<ParameterInfo>& parameterTable()
{
  static const std::vector<ParameterInfo> table = makeTable();
  return table;
}

const ParameterInfo* findParameter(const std::string& name)
{
  for (const ParameterInfo& info : parameterTable())
    if (name == info.name)
      return &info;
  return nullptr;
}

std::string parameterText(const ParameterInfo& info, const Parameters& p)
{
  if (isMaxDeviation(info) && p.max_deviation_of_L != 0.0)
    return formatNumber(100.0 * p.max_deviation_of_L) + "%";
  return std::visit(
      [&](auto member) -> std::string {
        using T = std::decay_t<decltype(p.*member)>;
        const T& v = p.*member;
        if constexpr (std::is_same<T, double>::value)
          return formatNumber(v);
        else if constexpr (std::is_same<T, bool>::value)
          return v == info.switch_value ? "true" : "false";
        else if constexpr (std::is_same<T, ErrorForm>::value)
          return toString(v);
        else
          return std::to_string(v);
      },
      info.member);
}

std::string setParameter(const ParameterInfo& info, const std::string& text, Parameters& p)
{
  if (isMaxDeviation(info))
  {
    // D in the input's units, or "P%" of L.
    const bool percent = !text.empty() && text.back() == '%';
    double v = 0;
    std::string why = parseReal(percent ? text.substr(0, text.size() - 1) : text, v);
    if (!why.empty())
      return "'" + text + "' is not a number or a percentage";
    p.max_deviation = percent ? 0.0 : v;
    p.max_deviation_of_L = percent ? v / 100.0 : 0.0;
    return {};
  }
  return std::visit(
      [&](auto member) -> std::string {
        using T = std::decay_t<decltype(p.*member)>;
        if constexpr (std::is_same<T, bool>::value)
        {
          if (text != "true" && text != "false")
            return "'" + text + "' is not true or false";
          if (text == "true")
            p.*member = info.switch_value;
          return {};
        }
        else if constexpr (std::is_same<T, ErrorForm>::value)
        {
          return parseErrorForm(text, p.*member) ? std::string() : "'" + text + "' is not 'normalized' or 'paper'";
        }
        else if constexpr (std::is_same<T, double>::value)
        {
          double v = 0;
          std::string why = parseReal(text, v);
          if (why.empty())
            p.*member = v;
          return why;
        }
        else
        {
          long long v = 0;
          std::string why = parseInteger(text, v);
          if (!why.empty())
            return why;
          if (std::is_unsigned<T>::value && v < 0)
            return "'" + text + "' must not be negative";
          if (static_cast<long double>(v) < static_cast<long double>(std::numeric_limits<T>::min()) ||
              static_cast<long double>(v) > static_cast<long double>(std::numeric_limits<T>::max()))
            return "'" + text + "' is out of range: must be " + info.range;
          p.*member = static_cast<T>(v);
          return {};
        }
      },
      info.member);
}

std::string parseReal(const std::string& text, double& value)
{
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
    return "'" + text + "' is not a number";
  if (!std::isfinite(v))
    return "'" + text + "' is not a finite number";
  value = v;
  return {};
}

std::string parseInteger(const std::string& text, long long& value)
{
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
    return "'" + text + "' is not an integer";
  value = v;
  return {};
}

bool inRange(const ParameterInfo& info, const Parameters& p)
{
  if (isMaxDeviation(info))
    return numberInRange(info, p.max_deviation) && std::isfinite(p.max_deviation_of_L) &&
           p.max_deviation_of_L >= 0.0 && p.max_deviation_of_L <= 1.0 &&
           !(p.max_deviation > 0.0 && p.max_deviation_of_L > 0.0);
  return std::visit(
      [&](auto member) -> bool {
        using T = std::decay_t<decltype(p.*member)>;
        const T& v = p.*member;
        if constexpr (std::is_same<T, bool>::value)
          return true;
        else if constexpr (std::is_same<T, ErrorForm>::value)
          return v == ErrorForm::Normalized || v == ErrorForm::Paper;
        else
          return numberInRange(info, static_cast<double>(v));
      },
      info.member);
}

std::string validate(const Parameters& p)
{
  for (const ParameterInfo& info : parameterTable())
  {
    if (inRange(info, p))
      continue;
    std::ostringstream os;
    os << info.field;
    if (*info.symbol)
      os << " (" << info.symbol << ")";
    std::visit(
        [&](auto member) {
          using T = std::decay_t<decltype(p.*member)>;
          if constexpr (!std::is_same<T, ErrorForm>::value)
            os << " = " << +(p.*member);  // as a stream prints it: "2", "0.5", "1e-06"
        },
        info.member);
    os << " is invalid: must be " << info.range;
    if (isMaxDeviation(info) && p.max_deviation_of_L != 0.0)
      os << " (max_deviation_of_L = " << p.max_deviation_of_L << ", a fraction of L in (0, 1], and not with "
         << "max_deviation as well)";
    return os.str();
  }
  if (p.error_threshold_abs > 0.0 && p.target_size > 0)
    return "error_threshold_abs cannot be combined with target_size: give the error bound or the size";
  if ((p.max_deviation > 0.0 || p.max_deviation_of_L > 0.0) && p.target_size > 0)
    return "max_deviation cannot be combined with target_size: the points it adds change the size";
  return {};
}

}  // namespace pcl_ecs
