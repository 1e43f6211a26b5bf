#include <pcl_ecs/parameters.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <thread>

namespace pcl_ecs
{

const char* toString(ErrorForm form)
{
  return form == ErrorForm::Paper ? "paper" : "normalized";
}

bool parseErrorForm(const std::string& text, ErrorForm& form)
{
  if (text == "normalized")
  {
    form = ErrorForm::Normalized;
    return true;
  }
  if (text == "paper")
  {
    form = ErrorForm::Paper;
    return true;
  }
  return false;
}

namespace
{
std::string bad(const char* name, double value, const char* range)
{
  std::ostringstream os;
  os << name << " = " << value << " is invalid: must be " << range;
  return os.str();
}
}  // namespace

std::string validate(const Parameters& p)
{
  if (!(std::isfinite(p.error_threshold) && p.error_threshold > 0.0 && p.error_threshold < 1.0))
    return bad("error_threshold (T_err)", p.error_threshold, "in (0, 1)");
  if (!(std::isfinite(p.feature_factor) && p.feature_factor > 0.0))
    return bad("feature_factor (alpha)", p.feature_factor, "a finite number > 0");
  if (p.k_neighbors < 5 || p.k_neighbors > 200)
    return bad("k_neighbors (K)", p.k_neighbors, "an integer in [5, 200]");
  if (!(std::isfinite(p.adaptive_factor) && p.adaptive_factor >= 1.0 && p.adaptive_factor <= 100.0))
    return bad("adaptive_factor", p.adaptive_factor, "in [1, 100]");
  if (!(std::isfinite(p.radius_cap_factor) && p.radius_cap_factor > 0.0 &&
        p.radius_cap_factor <= 1000.0))
    return bad("radius_cap_factor", p.radius_cap_factor, "in (0, 1000]");
  if (!(std::isfinite(p.target_radius_cap) && p.target_radius_cap >= 0.0 && p.target_radius_cap <= 1000.0))
    return bad("target_radius_cap", p.target_radius_cap, "0 (off) or in (0, 1000]");
  if (!(std::isfinite(p.max_representative_offset) && p.max_representative_offset > 0.0 &&
        p.max_representative_offset <= 1.0))
    return bad("max_representative_offset", p.max_representative_offset, "in (0, 1]");
  if (!(std::isfinite(p.representative_cutoff) && p.representative_cutoff > 0.0 && p.representative_cutoff <= 1.0))
    return bad("representative_cutoff", p.representative_cutoff, "in (0, 1]");
  if (!(std::isfinite(p.max_roughness) && p.max_roughness > 0.0 && p.max_roughness <= 10.0))
    return bad("max_roughness", p.max_roughness, "in (0, 10]");
  if (!(std::isfinite(p.max_gap_factor) && p.max_gap_factor >= 0.0 && p.max_gap_factor <= 100.0))
    return bad("max_gap_factor", p.max_gap_factor, "0 (off) or in (0, 100]");
  if (!(std::isfinite(p.target_gap_factor) && p.target_gap_factor >= 0.0 && p.target_gap_factor <= 100.0))
    return bad("target_gap_factor", p.target_gap_factor, "0 (off) or in (0, 100]");
  if (p.threads < 0 || p.threads > 1024)
    return bad("threads", p.threads, "an integer in [0, 1024] (0 = all hardware threads)");
  if (p.error_form != ErrorForm::Normalized && p.error_form != ErrorForm::Paper)
    return "error_form is invalid: must be normalized or paper";
  return {};
}

int resolveThreads(int requested)
{
  if (requested > 0)
    return requested;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw == 0 ? 1 : static_cast<int>(std::min(hw, 1024u));
}

}  // namespace pcl_ecs
