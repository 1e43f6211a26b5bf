// parameter_table.h: every parameter of the method once, with its one spelling, its range and its
// help. validate() checks the ranges of this table; pcd_simplify's and ecs_node's flags, the
// --stats JSON keys, the launch files' filter keys and the out-of-core run's resume fingerprint are
// generated from it. The spelling is the command line's: `--max-gap` is "max-gap" in JSON and in a
// launch file. The Parameters member (and the Python keyword) is `field`.
#pragma once

#include <pcl_ecs/parameters.h>

#include <cstdint>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

namespace pcl_ecs
{

static_assert(std::is_same<std::size_t, std::uint64_t>::value, "target_size is stored as a 64-bit count");

/** \brief The member of Parameters a table row describes. */
using ParameterField = std::variant<double Parameters::*, int Parameters::*, std::uint64_t Parameters::*,
                                    bool Parameters::*, ErrorForm Parameters::*>;

/** \brief One parameter. */
struct ParameterInfo
{
  const char* name;        ///< the one spelling: the flag without "--", the JSON and launch-file key
  const char* field;       ///< the Parameters member, the Python keyword
  const char* symbol;      ///< the paper's symbol, named in messages ("T_err"), or ""
  ParameterField member;   ///< where the value lives
  const char* metavar;     ///< the value's name in --help ("T" in "--terr T"); "" for a switch
  /// A switch (a flag without a value) sets a bool member to this value.
  bool switch_value;
  double min, max;         ///< the range (numbers)
  bool min_open, max_open; ///< (min, ...) rather than [min, ...]; [..., max) rather than [..., max]
  bool zero_allowed;       ///< 0 (off) is valid besides the range
  const char* range;       ///< the range as messages say it ("in (0, 1)")
  const char* help;        ///< what --help says of it (the default is added)
  bool changes_output;     ///< false for what never changes the output (threads)
};

/** \brief Every parameter, in the order --help lists them. */
const std::vector<ParameterInfo>& parameterTable();

/** \brief The row of `name` (the one spelling, without "--"), or nullptr. */
const ParameterInfo* findParameter(const std::string& name);

/** \brief The value of a row in `p` as text: numbers in the fewest digits that read back exactly, switches "true" /
 * "false" (whether the switch is given), the error form by name. */
std::string parameterText(const ParameterInfo& info, const Parameters& p);

/** \brief Sets a row's member of `p` from text; returns why the text is not a value of it (empty
 * when it is). A switch takes "true" (set) or "false" (left as it is). Ranges are validate()'s. */
std::string setParameter(const ParameterInfo& info, const std::string& text, Parameters& p);

/** \brief Reads a finite number from the whole of `text`; returns why it is not one ("'x' is
 * not a number", "... not a finite number"), empty when it is. */
std::string parseReal(const std::string& text, double& value);

/** \brief Reads an integer from the whole of `text`; returns why it is not one, empty when it is. */
std::string parseInteger(const std::string& text, long long& value);

/** \brief Whether a row's value in `p` lies in its range (validate() for one row). */
bool inRange(const ParameterInfo& info, const Parameters& p);

}  // namespace pcl_ecs
