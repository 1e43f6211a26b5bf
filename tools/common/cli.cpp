#include "cli.h"

#include <pcl_ecs/parameter_table.h>
#include <pcl_ecs/version.h>

#include <algorithm>

#include <cstdio>
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
  double v = 0;
  const std::string why = parseReal(text, v);
  if (!why.empty())
    throw UsageError(flag + ": " + why);
  return v;
}

std::int64_t parseIntFlag(const std::string& flag, const std::string& text)
{
  long long v = 0;
  const std::string why = parseInteger(text, v);
  if (!why.empty())
    throw UsageError(flag + ": " + why);
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
  if (flag.rfind("--", 0) != 0)
    return false;
  const ParameterInfo* info = findParameter(flag.substr(2));
  if (!info)
    return false;
  const bool is_switch = *info->metavar == '\0';
  const std::string why = setParameter(*info, is_switch ? std::string("true") : value(), p);
  if (!why.empty())
    throw UsageError(flag + ": " + why);
  if (flag == "--target-size" && p.target_size == 0)
    throw UsageError(flag + ": must be at least 1");
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
  if (args.given("--terr-abs") && (target || args.given("--terr")))
    throw UsageError(std::string("--terr-abs and ") +
                     (args.given("--terr") ? "--terr" : target_ratio_given ? "--target-ratio" : "--target-size") +
                     " exclude each other: give one error bound, or the size");
  if (args.given("--feature-spacing") && target)
    throw UsageError(std::string("--feature-spacing and ") + (target_ratio_given ? "--target-ratio" : "--target-size") +
                     " exclude each other: a target size thins the feature points itself");
  if (args.given("--max-deviation") && target)
    throw UsageError(std::string("--max-deviation and ") + (target_ratio_given ? "--target-ratio" : "--target-size") +
                     " exclude each other: the points the bound adds change the size");
}

std::string filterFlagsHelp()
{
  const Parameters d;
  std::ostringstream os;
  os << "Method (defaults are the library's):\n";
  constexpr std::size_t kIndent = 22, kWidth = 100;
  for (const ParameterInfo& info : parameterTable())
  {
    std::string head = std::string("  --") + info.name;
    if (*info.metavar)
      head += std::string(" ") + info.metavar;
    std::string text = info.help;
    if (*info.metavar)
      text += std::string("; ") + info.range + " (default " + parameterText(info, d) + ")";
    // The flag, then its text wrapped at kWidth columns under kIndent.
    std::string line = head.size() + 1 < kIndent ? head + std::string(kIndent - head.size(), ' ') : head + "\n" + std::string(kIndent, ' ');
    std::size_t column = line.size() - (line.rfind('\n') == std::string::npos ? 0 : line.rfind('\n') + 1);
    std::istringstream words(text);
    std::string word;
    bool first = true;
    while (words >> word)
    {
      if (!first && column + 1 + word.size() > kWidth)
      {
        line += "\n" + std::string(kIndent, ' ');
        column = kIndent;
      }
      else if (!first)
      {
        line += ' ';
        ++column;
      }
      line += word;
      column += word.size();
      first = false;
    }
    os << line << "\n";
  }
  return os.str();
}

bool printedHelpOrVersion(const std::string& flag, const char* tool, const std::function<std::string()>& help)
{
  if (flag == "--help" || flag == "-h")
    std::fputs(help().c_str(), stdout);
  else if (flag == "--version")
    std::printf("%s (pcl_ecs) %s\n", tool, PCL_ECS_VERSION_STRING);
  else
    return false;
  return true;
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
