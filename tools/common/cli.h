// cli.h — what every pcl_ecs tool shares: exit codes, strict flag values, the filter flags that
// fill pcl_ecs::Parameters (validated by the library's own validate()), and the progress line.
#pragma once

#include <pcl_ecs/parameters.h>
#include <pcl_ecs/simplify_core.h>

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>
#include <stdexcept>
#include <string>

namespace pcl_ecs
{
namespace tools
{

/** \brief Documented exit codes of every tool. */
enum ExitCode : int
{
  kExitOk = 0,
  kExitInternal = 1,  ///< a bug or resource exhaustion: please report
  kExitUsage = 2,     ///< bad command line: unknown flag, bad value, same input and output
  kExitInput = 3,     ///< the input cannot be read or is not a usable cloud
  kExitOutput = 4     ///< an output cannot be written
};

/** \brief A bad command line; what() is the one line to print. */
struct UsageError : std::runtime_error
{
  using std::runtime_error::runtime_error;
};

/** \brief A failure with its exit code and one line for the user. */
struct ToolError : std::runtime_error
{
  ToolError(int c, const std::string& what) : std::runtime_error(what), code(c) {}
  int code;
};

/** \brief `message` as one safe line for a terminal or a log: control characters (escape
 * sequences, newlines from a file's content) become '?', and at most `max_chars` characters are
 * kept, with a count of the rest. */
std::string printable(const std::string& message, std::size_t max_chars = 400);

/** \brief Run `body` and turn what it throws into "tool: message" on stderr and the documented
 * exit code (UsageError 2, ToolError its own, out of memory and anything else 1). */
int runToolMain(const char* tool, const std::function<int()>& body);

/** \brief Keep freed memory in the process for the next stage instead of handing it back to the
 * kernel (glibc: blocks up to 32 MiB from the heap, the heap top trimmed only past 1 GiB free).
 * A run allocates and frees a few large arrays per stage (per tile with --stream); with glibc's
 * defaults each comes back as fresh pages the kernel must fault in and zero again, and on a VM that
 * returns freed pages to its host each of those faults costs microseconds (docs/BENCHMARKS.md).
 * For short-lived batch tools; the streaming runner still trims when its resident
 * set passes half the memory limit. A no-op without glibc. */
void keepFreedMemory();

/** \brief Walks the command line: `for (ArgWalker args(argc, argv); args.next();)`, then
 * `args.flag()` is the current word and `args.value()` takes its value: the text after '=' in
 * `--flag=value`, else the next word (UsageError "FLAG needs a value" at the end of the line). A
 * `--flag=value` whose flag takes no value is a UsageError. `given(flag)` says whether a flag was
 * on the line (for flags that exclude each other). */
class ArgWalker
{
public:
  ArgWalker(int argc, char** argv) : argc_(argc), argv_(argv) {}
  bool next()
  {
    if (inline_value_)
      throw UsageError(flag_ + " takes no value (got '" + flag_ + "=" + *inline_value_ + "')");
    if (++i_ >= argc_)
      return false;
    flag_ = argv_[i_];
    const std::size_t eq = flag_.find('=');
    if (flag_.rfind("--", 0) == 0 && eq != std::string::npos && eq > 2)
    {
      inline_value_ = flag_.substr(eq + 1);
      flag_.resize(eq);
    }
    if (flag_.size() > 1 && flag_[0] == '-')
      seen_.push_back(flag_);
    return true;
  }
  const std::string& flag() const { return flag_; }
  std::string value()
  {
    if (inline_value_)
    {
      std::string v = std::move(*inline_value_);
      inline_value_.reset();
      return v;
    }
    if (i_ + 1 >= argc_)
      throw UsageError(flag_ + " needs a value");
    return argv_[++i_];
  }
  bool given(const std::string& flag) const
  {
    for (const auto& f : seen_)
      if (f == flag)
        return true;
    return false;
  }

private:
  int argc_;
  char** argv_;
  int i_ = 0;
  std::string flag_;
  std::optional<std::string> inline_value_;
  std::vector<std::string> seen_;
};

/** \brief Strict number parsing: the whole text must be the number. Throw UsageError naming
 * the flag. */
double parseDoubleFlag(const std::string& flag, const std::string& text);
std::int64_t parseIntFlag(const std::string& flag, const std::string& text);
std::uint64_t parseUnsignedFlag(const std::string& flag, const std::string& text);

/** \brief If `flag` is one of the filter flags, read its value through `value()` (called only
 * for flags that take one), store it in `params` and return true. */
bool applyFilterFlag(const std::string& flag, const std::function<std::string()>& value,
                     Parameters& params);

/** \brief Refuse filter flags that contradict each other or have no effect (UsageError): --terr with a
 * target size, --target-cap or --target-gap without one, --adapt-factor with --no-adapt. */
void checkFilterFlagConflicts(const ArgWalker& args, bool target_ratio_given);

/** \brief The --help text of the filter flags, with the library's defaults. */
std::string filterFlagsHelp();

/// `--help` / `-h` prints `help()`, `--version` prints "TOOL (pcl_ecs) VERSION", both on stdout:
/// true when `flag` was one of them (the tool then exits 0).
bool printedHelpOrVersion(const std::string& flag, const char* tool, const std::function<std::string()>& help);

/** \brief A progress line on stderr ("\r<prefix>: stage 42%"), only when `enabled` (a terminal
 * and not --quiet); finish() clears it. */
class ProgressLine
{
public:
  ProgressLine(std::string prefix, bool enabled);
  ProgressCallback callback();
  void finish();

private:
  std::string prefix_;
  bool enabled_;
  bool dirty_ = false;
};

/** \brief True when stderr is a terminal. */
bool stderrIsTerminal();

}  // namespace tools
}  // namespace pcl_ecs
