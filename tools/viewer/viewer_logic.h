// viewer_logic.h — everything of pcl_ecs_viewer that does not draw: its options, its colour maps
// and the layout of its viewports (unit-tested in tests/test_viewer_logic.cpp).
#pragma once

#include <pcl_ecs/parameters.h>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace pcl_ecs
{
namespace viewer
{

using Rgb = std::array<std::uint8_t, 3>;

/** \brief How the points are coloured (key 'm' cycles). */
enum class ColourMode
{
  Label,      ///< grey original, red features, blue representatives
  Curvature,  ///< |H| of eq. 11 on a blue-to-yellow ramp
  Ball,       ///< each ball (or nearest simplified point) its own colour
  Input       ///< the input's own RGB (grey when it has none)
};

const char* toString(ColourMode mode);
bool parseColourMode(const std::string& text, ColourMode& mode);
ColourMode nextColourMode(ColourMode mode);

/** \brief The fixed colours of the label mode (also the legend's). */
constexpr Rgb kOriginalColour = {170, 170, 170};
constexpr Rgb kFeatureColour = {230, 30, 30};
constexpr Rgb kRepresentativeColour = {40, 90, 230};
constexpr Rgb kMeshColour = {200, 200, 160};

/** \brief A value in [lo, hi] on a perceptual blue → green → yellow ramp (clamped; NaN → grey). */
Rgb rampColour(double value, double lo, double hi);

/** \brief A well-spread colour for an integer id (golden-ratio hue walk); never the feature red. */
Rgb idColour(std::int64_t id);

/** \brief Viewport rectangles (xmin, ymin, xmax, ymax) for `count` side-by-side views. */
std::vector<std::array<double, 4>> viewportLayout(int count);

/** \brief The command line of the viewer. */
struct ViewerOptions
{
  std::string cloud;       ///< the original cloud (always)
  std::string simplified;  ///< a simplified cloud; empty: the viewer runs the filter itself
  std::string features;    ///< optional feature points file
  std::string mesh;        ///< optional mesh (PLY / OBJ / VTK) for a fourth view
  std::string screenshot;  ///< render offscreen to this PNG and exit
  int width = 1800, height = 600;
  ColourMode colour = ColourMode::Label;
  double point_size = 2.0;
  bool dark_background = true;
  Parameters params;       ///< filter parameters (when the viewer runs the filter)
  std::size_t interactive_limit = 2000000;  ///< re-run on key presses only up to this many points
  bool help = false;
};

/** \brief Parse the viewer's arguments; throws std::invalid_argument with a one-line reason. */
ViewerOptions parseViewerArgs(const std::vector<std::string>& args);

/** \brief The --help text. */
std::string viewerUsage();

/** \brief The key help shown by 'h'. */
std::string viewerKeyHelp();

}  // namespace viewer
}  // namespace pcl_ecs
