// pcl_ecs_viewer --screenshot on the bunny, with no display (the viewer renders under an Xvfb it
// starts itself): a PNG of the asked size whose three thirds each show drawn points, and whose
// middle third shows the feature colour.
#include "viewer/viewer_logic.h"

#include <cstdlib>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPNGReader.h>

namespace fs = std::filesystem;

namespace
{
/// The viewer command with no display at all: the viewer must start its own Xvfb. In the
/// sanitizer build, leak detection is off for the viewer process only: Mesa's dlopened GL driver
/// and PCL's static initialisers leak a few hundred bytes at exit, outside our code (every other
/// AddressSanitizer / UBSan check stays on).
std::string viewerCommand(const std::string& args)
{
  return std::string("env -u DISPLAY ASAN_OPTIONS=detect_leaks=0 ") + PCL_ECS_VIEWER_PATH + " " + args +
         " > /dev/null 2>&1";
}
}  // namespace

TEST(ViewerScreenshot, BunnyThreeViewsWithFeatures)
{
  const fs::path png = fs::temp_directory_path() / "pcl_ecs_viewer_test.png";
  fs::remove(png);
  const std::string cmd = viewerCommand(std::string(PCL_ECS_SHARED_DATA_DIR) + "/bunny.pcd --alpha 3.5 --point-size 3 --screenshot " +
                                        png.string() + " --size 900x300");
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  ASSERT_TRUE(fs::exists(png));
  vtkNew<vtkPNGReader> reader;
  reader->SetFileName(png.c_str());
  reader->Update();
  vtkImageData* img = reader->GetOutput();
  int dims[3];
  img->GetDimensions(dims);
  EXPECT_EQ(dims[0], 900);
  EXPECT_EQ(dims[1], 300);
  const int comps = img->GetNumberOfScalarComponents();
  ASSERT_GE(comps, 3);
  const auto* px = static_cast<const unsigned char*>(img->GetScalarPointer());
  const unsigned char bg = static_cast<unsigned char>(0.08 * 255);  // dark background
  std::size_t drawn[3] = {0, 0, 0}, red[3] = {0, 0, 0};
  for (int y = 40; y < dims[1] - 40; ++y)  // away from the text overlays
    for (int x = 0; x < dims[0]; ++x)
    {
      const unsigned char* p = px + (static_cast<std::size_t>(y) * dims[0] + x) * comps;
      const int third = std::min(2, x * 3 / dims[0]);
      if (std::abs(p[0] - bg) > 30 || std::abs(p[1] - bg) > 30 || std::abs(p[2] - bg) > 30)
        ++drawn[third];
      if (p[0] > 170 && p[1] < 90 && p[2] < 90)
        ++red[third];
    }
  for (int t = 0; t < 3; ++t)
    EXPECT_GT(drawn[t], 500u) << "third " << t << " shows no points";
  EXPECT_GT(red[1], 50u) << "no feature colour in the middle view";
  EXPECT_EQ(red[0], 0u) << "the original view must not show the feature colour";
  fs::remove(png);
}

TEST(ViewerScreenshot, BadInputGivesExitCode3AndNoPicture)
{
  const fs::path png = fs::temp_directory_path() / "pcl_ecs_viewer_bad.png";
  fs::remove(png);
  const int status = std::system(viewerCommand("/nonexistent.pcd --screenshot " + png.string()).c_str());
  EXPECT_EQ(WEXITSTATUS(status), 3);
  EXPECT_FALSE(fs::exists(png));
}
