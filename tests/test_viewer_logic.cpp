// The viewer's logic that does not draw: options, colour maps, layout.
#include "viewer/viewer_logic.h"

#include <cmath>
#include <set>
#include <stdexcept>

#include <gtest/gtest.h>

using namespace pcl_ecs::viewer;

TEST(ViewerLogic, ParsesOneAndTwoClouds)
{
  ViewerOptions o = parseViewerArgs({"a.pcd"});
  EXPECT_EQ(o.cloud, "a.pcd");
  EXPECT_TRUE(o.simplified.empty());
  EXPECT_EQ(o.width, 1800);
  EXPECT_EQ(o.colour, ColourMode::Label);
  o = parseViewerArgs({"a.pcd", "b.pcd", "--features", "f.pcd", "--mesh", "m.ply", "--screenshot",
                       "s.png", "--size", "900x300", "--colour", "curvature", "--terr", "2e-3",
                       "--alpha", "4", "--point-size", "3", "--light"});
  EXPECT_EQ(o.simplified, "b.pcd");
  EXPECT_EQ(o.features, "f.pcd");
  EXPECT_EQ(o.mesh, "m.ply");
  EXPECT_EQ(o.screenshot, "s.png");
  EXPECT_EQ(o.width, 900);
  EXPECT_EQ(o.height, 300);
  EXPECT_EQ(o.colour, ColourMode::Curvature);
  EXPECT_DOUBLE_EQ(o.params.error_threshold, 2e-3);
  EXPECT_DOUBLE_EQ(o.params.feature_factor, 4.0);
  EXPECT_DOUBLE_EQ(o.point_size, 3.0);
  EXPECT_FALSE(o.dark_background);
  EXPECT_TRUE(parseViewerArgs({"--help"}).help);
}

TEST(ViewerLogic, RefusesBadArguments)
{
  for (const std::vector<std::string>& bad :
       {std::vector<std::string>{}, {"a", "b", "c"}, {"a", "--size", "10x10"}, {"a", "--size", "axb"},
        {"a", "--size", "900"}, {"a", "--colour", "pink"}, {"a", "--terr", "-1"}, {"a", "--alpha", "nan"},
        {"a", "--point-size", "0"}, {"a", "--bogus"}, {"a", "--features", "f.pcd"}, {"a", "--screenshot"}})
    EXPECT_THROW(parseViewerArgs(bad), std::invalid_argument) << bad.size();
}

TEST(ViewerLogic, ColourModesCycleThroughAllFour)
{
  std::set<ColourMode> seen;
  ColourMode m = ColourMode::Label;
  for (int i = 0; i < 4; ++i)
  {
    seen.insert(m);
    ColourMode parsed;
    ASSERT_TRUE(parseColourMode(toString(m), parsed));
    EXPECT_EQ(parsed, m);
    m = nextColourMode(m);
  }
  EXPECT_EQ(seen.size(), 4u);
  EXPECT_EQ(m, ColourMode::Label);
}

TEST(ViewerLogic, RampEndsAndClamping)
{
  EXPECT_EQ(rampColour(0.0, 0.0, 1.0), (Rgb{30, 40, 150}));
  EXPECT_EQ(rampColour(1.0, 0.0, 1.0), (Rgb{250, 230, 40}));
  EXPECT_EQ(rampColour(0.5, 0.0, 1.0), (Rgb{40, 170, 90}));
  EXPECT_EQ(rampColour(-5.0, 0.0, 1.0), rampColour(0.0, 0.0, 1.0));
  EXPECT_EQ(rampColour(9.0, 0.0, 1.0), rampColour(1.0, 0.0, 1.0));
  EXPECT_EQ(rampColour(std::nan(""), 0.0, 1.0), kOriginalColour);
  // Monotone in green up to the middle.
  EXPECT_LT(rampColour(0.1, 0, 1)[1], rampColour(0.4, 0, 1)[1]);
}

TEST(ViewerLogic, IdColoursAreDistinctAndNeverTheFeatureRed)
{
  std::set<Rgb> colours;
  for (std::int64_t id = 0; id < 200; ++id)
  {
    const Rgb c = idColour(id);
    colours.insert(c);
    EXPECT_NE(c, kFeatureColour);
    // Not red-dominant like the feature colour (the screenshot test relies on it).
    EXPECT_FALSE(c[0] > 200 && c[1] < 80 && c[2] < 80) << id;
  }
  EXPECT_GT(colours.size(), 150u);
  EXPECT_EQ(idColour(7), idColour(7));
}

TEST(ViewerLogic, ViewportsTileTheWindow)
{
  const auto r = viewportLayout(3);
  ASSERT_EQ(r.size(), 3u);
  EXPECT_DOUBLE_EQ(r[0][0], 0.0);
  EXPECT_DOUBLE_EQ(r[0][2], r[1][0]);
  EXPECT_DOUBLE_EQ(r[2][2], 1.0);
  EXPECT_DOUBLE_EQ(r[1][1], 0.0);
  EXPECT_DOUBLE_EQ(r[1][3], 1.0);
  EXPECT_EQ(viewportLayout(4).size(), 4u);
}

TEST(ViewerLogic, HelpMentionsEveryKey)
{
  const std::string h = viewerKeyHelp();
  for (const char* k : {"h ", "m ", "t / T", "a / A", "n / N", "k "})
    EXPECT_NE(h.find(k), std::string::npos) << k;
  EXPECT_NE(viewerUsage().find("--screenshot"), std::string::npos);
}
