#include "viewer_logic.h"

#include "common/cli.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pcl_ecs
{
namespace viewer
{

const char* toString(ColourMode mode)
{
  switch (mode)
  {
  case ColourMode::Label: return "label";
  case ColourMode::Curvature: return "curvature";
  case ColourMode::Ball: return "ball";
  case ColourMode::Input: return "input";
  }
  return "label";
}

bool parseColourMode(const std::string& text, ColourMode& mode)
{
  for (ColourMode m : {ColourMode::Label, ColourMode::Curvature, ColourMode::Ball, ColourMode::Input})
    if (text == toString(m))
    {
      mode = m;
      return true;
    }
  return false;
}

ColourMode nextColourMode(ColourMode mode)
{
  switch (mode)
  {
  case ColourMode::Label: return ColourMode::Curvature;
  case ColourMode::Curvature: return ColourMode::Ball;
  case ColourMode::Ball: return ColourMode::Input;
  case ColourMode::Input: return ColourMode::Label;
  }
  return ColourMode::Label;
}

Rgb rampColour(double value, double lo, double hi)
{
  if (!std::isfinite(value))
    return kOriginalColour;
  double t = hi > lo ? (value - lo) / (hi - lo) : 0.0;
  t = std::min(std::max(t, 0.0), 1.0);
  // Three stops: dark blue (30, 40, 150), green (40, 170, 90), yellow (250, 230, 40).
  const double stops[3][3] = {{30, 40, 150}, {40, 170, 90}, {250, 230, 40}};
  const int seg = t < 0.5 ? 0 : 1;
  const double u = t < 0.5 ? t / 0.5 : (t - 0.5) / 0.5;
  Rgb c;
  for (int k = 0; k < 3; ++k)
    c[static_cast<std::size_t>(k)] =
        static_cast<std::uint8_t>(std::lround(stops[seg][k] + u * (stops[seg + 1][k] - stops[seg][k])));
  return c;
}

Rgb idColour(std::int64_t id)
{
  // Hue walk by the golden ratio; saturation and value vary a little with the id.
  const double golden = 0.6180339887498949;
  double h = std::fmod(0.13 + golden * static_cast<double>(id < 0 ? -id : id), 1.0);
  // Keep clear of pure red (the feature colour): hues within ±0.04 of 0 move away.
  if (h < 0.04 || h > 0.96)
    h = 0.08;
  const double s = 0.55 + 0.3 * static_cast<double>((id / 7) % 2);
  const double v = 0.75 + 0.2 * static_cast<double>((id / 3) % 2);
  const double hh = h * 6.0;
  const int sector = static_cast<int>(hh) % 6;
  const double f = hh - std::floor(hh);
  const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  double r = v, g = t, b = p;
  switch (sector)
  {
  case 0: r = v; g = t; b = p; break;
  case 1: r = q; g = v; b = p; break;
  case 2: r = p; g = v; b = t; break;
  case 3: r = p; g = q; b = v; break;
  case 4: r = t; g = p; b = v; break;
  default: r = v; g = p; b = q; break;
  }
  return {static_cast<std::uint8_t>(std::lround(255 * r)), static_cast<std::uint8_t>(std::lround(255 * g)),
          static_cast<std::uint8_t>(std::lround(255 * b))};
}

std::vector<std::array<double, 4>> viewportLayout(int count)
{
  std::vector<std::array<double, 4>> rects;
  for (int i = 0; i < count; ++i)
    rects.push_back({static_cast<double>(i) / count, 0.0, static_cast<double>(i + 1) / count, 1.0});
  return rects;
}

namespace
{
void parseSize(const std::string& text, int& w, int& h)
{
  const auto x = text.find('x');
  if (x == std::string::npos)
    throw std::invalid_argument("--size: '" + text + "' is not WIDTHxHEIGHT");
  const auto W = tools::parseIntFlag("--size", text.substr(0, x));
  const auto H = tools::parseIntFlag("--size", text.substr(x + 1));
  if (W < 64 || H < 64 || W > 16384 || H > 16384)
    throw std::invalid_argument("--size: each side must be in [64, 16384]");
  w = static_cast<int>(W);
  h = static_cast<int>(H);
}
}  // namespace

ViewerOptions parseViewerArgs(const std::vector<std::string>& args)
{
  ViewerOptions o;
  std::vector<std::string> positional;
  try
  {
    for (std::size_t i = 0; i < args.size(); ++i)
    {
      const std::string& a = args[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= args.size())
          throw std::invalid_argument(a + " needs a value");
        return args[++i];
      };
      if (a == "--help" || a == "-h")
        o.help = true;
      else if (tools::applyFilterFlag(a, value, o.params))
        continue;
      else if (a == "--features")
        o.features = value();
      else if (a == "--mesh")
        o.mesh = value();
      else if (a == "--screenshot")
        o.screenshot = value();
      else if (a == "--size")
        parseSize(value(), o.width, o.height);
      else if (a == "--colour" || a == "--color")
      {
        const std::string v = value();
        if (!parseColourMode(v, o.colour))
          throw std::invalid_argument(a + ": '" + v + "' is not label, curvature, ball or input");
      }
      else if (a == "--point-size")
      {
        o.point_size = tools::parseDoubleFlag(a, value());
        if (!(o.point_size >= 1.0 && o.point_size <= 20.0))
          throw std::invalid_argument("--point-size: must be in [1, 20]");
      }
      else if (a == "--light")
        o.dark_background = false;
      else if (a.size() > 1 && a[0] == '-')
        throw std::invalid_argument("unknown option '" + a + "' (see --help)");
      else
        positional.push_back(a);
    }
  }
  catch (const tools::UsageError& e)
  {
    throw std::invalid_argument(e.what());
  }
  if (o.help)
    return o;
  if (positional.empty() || positional.size() > 2)
    throw std::invalid_argument("expected CLOUD [SIMPLIFIED] (see --help)");
  o.cloud = positional[0];
  if (positional.size() == 2)
    o.simplified = positional[1];
  if (!o.features.empty() && o.simplified.empty())
    throw std::invalid_argument("--features needs a SIMPLIFIED cloud too (with one cloud the viewer finds the features itself)");
  const std::string why = validate(o.params);
  if (!why.empty())
    throw std::invalid_argument(why);
  return o;
}

std::string viewerUsage()
{
  return "Usage: pcl_ecs_viewer CLOUD [SIMPLIFIED] [--features FILE] [--mesh MESH] [options]\n\n"
         "Shows side by side, with one shared camera: the original cloud; the original with its\n"
         "feature points highlighted; the simplified cloud (representatives and features in\n"
         "different colours); and, with --mesh, a mesh. Given one cloud it runs the filter itself\n"
         "(and T_err and alpha can be changed with keys); given two it shows them as they are.\n\n"
         "Options:\n"
         "  --screenshot FILE.png  render offscreen to FILE.png and exit; without a display the viewer\n"
         "                         starts a virtual one itself (xvfb-run, Debian package xvfb)\n"
         "  --size WxH             window / screenshot size (default 1800x600)\n"
         "  --colour MODE          label (default), curvature, ball or input\n"
         "  --point-size P         point size in pixels, [1, 20] (default 2)\n"
         "  --light                light background\n"
         "  and every filter flag of pcd_simplify (--terr, --alpha, --k, ...), used with one cloud\n\n" +
         viewerKeyHelp() +
         "\nExamples:\n"
         "  pcl_ecs_viewer scan.pcd                                # run the filter, look, tune keys\n"
         "  pcl_ecs_viewer scan.pcd small.pcd --features edges.pcd # compare files made by pcd_simplify\n"
         "  pcl_ecs_viewer bunny.pcd --screenshot bunny.png --size 1500x500\n";
}

std::string viewerKeyHelp()
{
  return "Keys:\n"
         "  h        show / hide this help in the window\n"
         "  m        next colour mode (label, curvature, ball, input)\n"
         "  t / T    T_err x1.5 / /1.5 and re-run the filter (one-cloud mode)\n"
         "  a / A    alpha +0.5 / -0.5 and re-run the filter (one-cloud mode)\n"
         "  n / N    larger / smaller points\n"
         "  k        dark / light background\n"
         "  r        reset the camera;  q  quit\n";
}

}  // namespace viewer
}  // namespace pcl_ecs
