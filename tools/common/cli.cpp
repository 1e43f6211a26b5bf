#include "cli.h"

#include <algorithm>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include <unistd.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif

namespace pcl_ecs
{
namespace tools
{

double parseDoubleFlag(const std::string& flag, const std::string& text)
{
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
    throw UsageError(flag + ": '" + text + "' is not a number");
  if (!std::isfinite(v))
    throw UsageError(flag + ": '" + text + "' is not a finite number");
  return v;
}

std::int64_t parseIntFlag(const std::string& flag, const std::string& text)
{
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE)
    throw UsageError(flag + ": '" + text + "' is not an integer");
  return v;
}

std::uint64_t parseUnsignedFlag(const std::string& flag, const std::string& text)
{
  const std::int64_t v = parseIntFlag(flag, text);
  if (v < 0)
    throw UsageError(flag + ": '" + text + "' must not be negative");
  return static_cast<std::uint64_t>(v);
}

bool applyFilterFlag(const std::string& flag, const std::function<std::string()>& value,
                     Parameters& p)
{
  if (flag == "--terr")
    p.error_threshold = parseDoubleFlag(flag, value());
  else if (flag == "--alpha")
    p.feature_factor = parseDoubleFlag(flag, value());
  else if (flag == "--k")
  {
    const std::int64_t k = parseIntFlag(flag, value());
    if (k < 0 || k > 100000)
      throw UsageError(flag + ": " + std::to_string(k) + " is out of range [5, 200]");
    p.k_neighbors = static_cast<int>(k);
  }
  else if (flag == "--error-form")
  {
    const std::string v = value();
    if (!parseErrorForm(v, p.error_form))
      throw UsageError(flag + ": '" + v + "' is not 'normalized' or 'paper'");
  }
  else if (flag == "--no-adapt")
    p.adaptive = false;
  else if (flag == "--adapt-factor")
    p.adaptive_factor = parseDoubleFlag(flag, value());
  else if (flag == "--radius-cap")
    p.radius_cap_factor = parseDoubleFlag(flag, value());
  else if (flag == "--rep-offset")
    p.max_representative_offset = parseDoubleFlag(flag, value());
  else if (flag == "--rep-cutoff")
    p.representative_cutoff = parseDoubleFlag(flag, value());
  else if (flag == "--max-roughness")
    p.max_roughness = parseDoubleFlag(flag, value());
  else if (flag == "--max-gap")
    p.max_gap_factor = parseDoubleFlag(flag, value());
  else if (flag == "--target-gap")
    p.target_gap_factor = parseDoubleFlag(flag, value());
  else if (flag == "--target-cap")
    p.target_radius_cap = parseDoubleFlag(flag, value());
  else if (flag == "--seed")
    p.seed = parseUnsignedFlag(flag, value());
  else if (flag == "--threads")
  {
    const std::int64_t t = parseIntFlag(flag, value());
    if (t < 0 || t > 1024)
      throw UsageError(flag + ": " + std::to_string(t) + " is out of range [0, 1024]");
    p.threads = static_cast<int>(t);
  }
  else if (flag == "--use-input-normals")
    p.use_input_normals = true;
  else if (flag == "--target-size")
  {
    p.target_size = parseUnsignedFlag(flag, value());
    if (p.target_size == 0)
      throw UsageError(flag + ": must be at least 1");
  }
  else
    return false;
  return true;
}

void checkFilterFlagConflicts(const ArgWalker& args, bool target_ratio_given)
{
  const bool target = args.given("--target-size") || target_ratio_given;
  if (args.given("--terr") && target)
    throw UsageError(std::string("--terr and ") + (target_ratio_given ? "--target-ratio" : "--target-size") +
                     " exclude each other: give the error bound or the size, the search finds the other");
  for (const char* flag : {"--target-cap", "--target-gap"})
    if (args.given(flag) && !target)
      throw UsageError(std::string(flag) + " applies only with --target-size or --target-ratio");
  if (args.given("--adapt-factor") && args.given("--no-adapt"))
    throw UsageError("--adapt-factor and --no-adapt exclude each other");
}

std::string filterFlagsHelp()
{
  const Parameters d;
  std::ostringstream os;
  os << "Method (defaults are the library's):\n"
     << "  --terr T            error bound T_err, a fraction of the bounding-box diagonal L, in (0, 1)\n"
     << "                      (default " << d.error_threshold << "); larger keeps fewer points\n"
     << "  --alpha A           feature factor α of eq. 4, > 0 (default " << d.feature_factor
     << "); larger keeps fewer feature points\n"
     << "  --k K               neighbourhood size, in [5, 200] (default " << d.k_neighbors << ")\n"
     << "  --error-form F      normalized (scale-free, default) or paper (the paper's literal eq. 14)\n"
     << "  --no-adapt          do not adapt T_err to local curvature and density (step 5)\n"
     << "  --adapt-factor F    adaptation factor, in [1, 100] (default " << d.adaptive_factor << ")\n"
     << "  --radius-cap C      largest ball radius, in mean neighbourhood radii, in (0, 1000]\n"
     << "                      (default " << d.radius_cap_factor << ")\n"
     << "  --rep-offset F      the optimised point stands for its ball when within F × r of the centre,\n"
     << "                      else the centre; the paper's rule is 1; in (0, 1] (default " << d.max_representative_offset << ")\n"
     << "  --rep-cutoff F      the optimised point moves from the centre only along the directions whose\n"
     << "                      eigenvalue is above F × the largest of its quadric; in (0, 1] (default "
     << d.representative_cutoff << ";\n"
     << "                      E(r) uses 0.001)\n"
     << "  --max-roughness F   a ball whose points scatter about their planes by more than F × r (RMS)\n"
     << "                      keeps its centre, an input point; in (0, 10] (default " << d.max_roughness
     << "; 2 = never)\n"
     << "  --max-gap G         no input point farther than G × the radius cap from the output: points\n"
     << "                      left farther become output points; 0 = off (the paper's method);\n"
     << "                      0 or in (0, 100] (default " << d.max_gap_factor << ")\n"
     << "  --target-gap G      the same with a target size, × the cap the target implies (default "
     << d.target_gap_factor << ")\n"
     << "  --seed S            seed of the centre order (default " << d.seed
     << "); same seed, same output\n"
     << "  --threads N         worker threads, 0 = all (default 0); the output does not depend on it\n"
     << "  --use-input-normals use the input's normals instead of estimating them\n"
     << "  --target-size N     aim at N output points (searches T_err; within 1% or the closest)\n"
     << "  --target-cap C      with a target size, the radius cap is C × the spacing the target implies\n"
     << "                      instead of --radius-cap; 0 = use --radius-cap (default " << d.target_radius_cap << ")\n";
  return os.str();
}

bool stderrIsTerminal()
{
  return ::isatty(STDERR_FILENO) == 1;
}

ProgressLine::ProgressLine(std::string prefix, bool enabled)
  : prefix_(std::move(prefix)), enabled_(enabled)
{
}

ProgressCallback ProgressLine::callback()
{
  if (!enabled_)
    return {};
  return [this](const char* stage, double fraction) {
    std::fprintf(stderr, "\r\033[K%s: %s %3.0f%%", prefix_.c_str(), stage, 100.0 * fraction);
    std::fflush(stderr);
    dirty_ = true;
  };
}

void ProgressLine::finish()
{
  if (enabled_ && dirty_)
  {
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
  }
  dirty_ = false;
}

void keepFreedMemory()
{
#ifdef __GLIBC__
  // 32 MiB is the largest mmap threshold mallopt accepts on 64-bit glibc; setting it also stops
  // glibc from moving the threshold on its own.
  ::mallopt(M_MMAP_THRESHOLD, 32 << 20);
  ::mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}

std::string printable(const std::string& message, std::size_t max_chars)
{
  std::string out;
  out.reserve(std::min(message.size(), max_chars) + 16);
  for (std::size_t i = 0; i < message.size(); ++i)
  {
    if (out.size() >= max_chars)
    {
      out += "... (" + std::to_string(message.size() - i) + " more bytes)";
      break;
    }
    const auto c = static_cast<unsigned char>(message[i]);
    out += (c < 0x20 || c == 0x7f) ? '?' : static_cast<char>(c);
  }
  return out;
}

int runToolMain(const char* tool, const std::function<int()>& body)
{
  try
  {
    return body();
  }
  catch (const UsageError& e)
  {
    std::fprintf(stderr, "%s: %s\n", tool, printable(e.what()).c_str());
    return kExitUsage;
  }
  catch (const ToolError& e)
  {
    std::fprintf(stderr, "%s: %s\n", tool, printable(e.what()).c_str());
    return e.code;
  }
  catch (const std::bad_alloc&)
  {
    std::fprintf(stderr, "%s: out of memory\n", tool);
    return kExitInternal;
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "%s: internal error: %s\n", tool, printable(e.what()).c_str());
    return kExitInternal;
  }
}

}  // namespace tools
}  // namespace pcl_ecs
