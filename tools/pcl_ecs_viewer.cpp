// pcl_ecs_viewer — the original, its feature points and the simplified cloud side by side, one
// shared camera; a fourth view for a mesh. Offscreen screenshots with --screenshot.
#include "common/cli.h"
#include "viewer/viewer_logic.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/feature_aware_cover_simplify.h>
#include <pcl_ecs/io/cloud_io.h>
#include <pcl_ecs/neighborhood.h>
#include <pcl_ecs/search/nanoflann_search.h>
#include <pcl_ecs/stages/normals.h>
#include <pcl_ecs/stages/paraboloid_curvature.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <unistd.h>
#include <iostream>
#include <sstream>

#include <pcl/common/centroid.h>
#include <pcl/common/common.h>
#include <pcl/conversions.h>
#include <pcl/console/print.h>
#include <pcl/io/vtk_lib_io.h>
#include <pcl/visualization/pcl_visualizer.h>
#include <vtkCamera.h>
#include <vtkNew.h>
#include <vtkPNGWriter.h>
#include <vtkWindowToImageFilter.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkRendererCollection.h>

using namespace pcl_ecs;
using namespace pcl_ecs::viewer;
using Cloud = pcl::PointCloud<pcl::PointXYZRGB>;

namespace
{

/// Everything shown, with per-point annotations.
struct Scene
{
  Cloud::Ptr original{new Cloud}, simplified{new Cloud};
  bool has_rgb = false;
  std::vector<std::uint8_t> original_feature, simplified_feature;
  std::vector<std::int64_t> original_ball, simplified_ball;
  std::vector<double> original_curvature, simplified_curvature;
  std::vector<float> original_shade, simplified_shade;
  pcl::PolygonMesh mesh;
  bool has_mesh = false;
  std::string summary;
  double curvature_hi = 1.0;
};

Cloud::Ptr loadCloud(const std::string& path, bool* has_rgb = nullptr, std::vector<std::uint8_t>* labels = nullptr)
{
  pcl::PCLPointCloud2 blob;
  io::readCloud(path, blob);
  auto cloud = std::make_shared<Cloud>();
  bool rgb = false;
  for (const auto& f : blob.fields)
    rgb = rgb || f.name == "rgb" || f.name == "rgba";
  if (rgb)
    pcl_ecs::io::fromCloud(blob, *cloud);
  else
  {
    pcl::PointCloud<pcl::PointXYZ> xyz;
    pcl_ecs::io::fromCloud(blob, xyz);
    pcl::copyPointCloud(xyz, *cloud);
  }
  if (has_rgb)
    *has_rgb = rgb;
  if (labels)
  {
    labels->clear();
    for (const auto& f : blob.fields)
      if (f.name == "ecs_label" && f.datatype == pcl::PCLPointField::UINT8)
        for (std::size_t i = 0; i < cloud->size(); ++i)
          labels->push_back(blob.data[i * blob.point_step + f.offset]);
  }
  // Only finite points are shown.
  Cloud::Ptr finite(new Cloud);
  std::vector<std::uint8_t> kept_labels;
  for (std::size_t i = 0; i < cloud->size(); ++i)
    if (pcl::isFinite((*cloud)[i]))
    {
      finite->push_back((*cloud)[i]);
      if (labels && !labels->empty())
        kept_labels.push_back((*labels)[i]);
    }
  if (labels && !labels->empty())
    *labels = kept_labels;
  return finite;
}

/// |H| (eq. 11) of every point, in a local frame, with the library's own stages; and a shade in
/// [0.35, 1] from the normal against a fixed light, so flat colours still read as a surface.
std::vector<double> curvatureOf(const Cloud& cloud, int k, std::vector<float>& shade)
{
  std::vector<double> H(cloud.size(), std::numeric_limits<double>::quiet_NaN());
  shade.assign(cloud.size(), 1.0f);
  if (cloud.size() <= static_cast<std::size_t>(k))
    return H;
  Eigen::Vector4f c;
  pcl::compute3DCentroid(cloud, c);
  auto local = std::make_shared<LocalCloud>();
  for (const auto& p : cloud)
    local->push_back(pcl::PointXYZ(p.x - c.x(), p.y - c.y(), p.z - c.z()));
  NanoflannSearch search;
  search.setInputCloud(local);
  NeighborhoodTable table;
  computeNeighborhoods(*local, search, k, resolveThreads(0), table);
  NormalList normals;
  estimateNormals(*local, table, resolveThreads(0), normals);
  const std::vector<std::uint8_t> none(local->size(), 0);
  computeMeanCurvature(*local, normals, table, none, resolveThreads(0), H);
  for (double& h : H)
    h = std::abs(h);
  const Eigen::Vector3f light = Eigen::Vector3f(0.3f, 0.5f, 0.8f).normalized();
  for (std::size_t i = 0; i < shade.size(); ++i)
    shade[i] = 0.35f + 0.65f * std::abs(normals[i].dot(light));
  return H;
}

/// For every point of `from`, the index of the nearest point of `to` (and its distance²).
std::vector<std::int64_t> nearestIn(const Cloud& from, const Cloud& to, std::vector<float>* d2_out = nullptr)
{
  auto xyz = std::make_shared<LocalCloud>();
  for (const auto& p : to)
    xyz->push_back(pcl::PointXYZ(p.x, p.y, p.z));
  NanoflannSearch search;
  search.setInputCloud(xyz);
  std::vector<std::int64_t> out(from.size(), -1);
  if (d2_out)
    d2_out->assign(from.size(), 0.f);
  pcl::Indices idx;
  std::vector<float> d2;
  for (std::size_t i = 0; i < from.size(); ++i)
    if (!to.empty() && search.nearestKSearch(pcl::PointXYZ(from[i].x, from[i].y, from[i].z), 1, idx, d2) == 1)
    {
      out[i] = idx[0];
      if (d2_out)
        (*d2_out)[i] = d2[0];
    }
  return out;
}

/// Curvature and shade of each simplified point: those of its nearest original point.
void annotateSimplified(Scene& s)
{
  const auto nearest = nearestIn(*s.simplified, *s.original);
  s.simplified_curvature.assign(s.simplified->size(), std::numeric_limits<double>::quiet_NaN());
  s.simplified_shade.assign(s.simplified->size(), 1.0f);
  for (std::size_t i = 0; i < nearest.size(); ++i)
    if (nearest[i] >= 0 && !s.original_curvature.empty())
    {
      s.simplified_curvature[i] = s.original_curvature[static_cast<std::size_t>(nearest[i])];
      s.simplified_shade[i] = s.original_shade[static_cast<std::size_t>(nearest[i])];
    }
}

void runFilter(Scene& s, const Parameters& params)
{
  FeatureAwareCoverSimplify<pcl::PointXYZRGB> f;
  f.setParameters(params);
  f.setInputCloud(s.original);
  f.filter(*s.simplified);
  const Result& r = f.getResult();
  if (!r.error.empty())
    throw std::runtime_error(r.error);
  s.original_feature.assign(s.original->size(), 0);
  s.simplified_feature.assign(s.simplified->size(), 0);
  for (std::size_t o = 0; o < s.simplified->size(); ++o)
    if (r.labels[o] == PointLabel::Feature)
    {
      s.simplified_feature[o] = 1;
      s.original_feature[static_cast<std::size_t>(r.source_index[o])] = 1;
    }
  s.original_ball = r.input_to_output;
  s.simplified_ball.resize(s.simplified->size());
  for (std::size_t o = 0; o < s.simplified_ball.size(); ++o)
    s.simplified_ball[o] = static_cast<std::int64_t>(o);
  std::ostringstream os;
  os.precision(3);
  os << "T_err " << r.summary.error_threshold << "  alpha " << params.feature_factor << "  K "
     << params.k_neighbors << "  " << r.summary.finite_points << " -> " << r.summary.output_points
     << " points (" << r.summary.feature_points << " features, " << r.summary.balls << " balls)  "
     << r.summary.timings.total << " s";
  s.summary = os.str();
}

void loadScene(Scene& s, const ViewerOptions& o)
{
  s.original = loadCloud(o.cloud, &s.has_rgb);
  if (s.original->empty())
    throw std::runtime_error(o.cloud + ": no finite points");
  if (o.simplified.empty())
    runFilter(s, o.params);
  else
  {
    std::vector<std::uint8_t> labels;
    s.simplified = loadCloud(o.simplified, nullptr, &labels);
    s.simplified_feature.assign(s.simplified->size(), 0);
    s.original_feature.assign(s.original->size(), 0);
    Eigen::Vector4f lo, hi;
    pcl::getMinMax3D(*s.original, lo, hi);
    const float tol2 = std::pow(1e-6f * (hi - lo).head<3>().norm(), 2.0f);
    if (!o.features.empty())
    {
      const Cloud::Ptr feats = loadCloud(o.features);
      std::vector<float> d2;
      nearestIn(*s.original, *feats, &d2);
      for (std::size_t i = 0; i < d2.size(); ++i)
        s.original_feature[i] = !feats->empty() && d2[i] <= tol2;
      nearestIn(*s.simplified, *feats, &d2);
      for (std::size_t i = 0; i < d2.size(); ++i)
        s.simplified_feature[i] = !feats->empty() && d2[i] <= tol2;
    }
    else if (!labels.empty())
    {
      for (std::size_t i = 0; i < labels.size(); ++i)
        s.simplified_feature[i] = labels[i] == static_cast<std::uint8_t>(PointLabel::Feature);
      Cloud feats;
      for (std::size_t i = 0; i < labels.size(); ++i)
        if (s.simplified_feature[i])
          feats.push_back((*s.simplified)[i]);
      std::vector<float> d2;
      nearestIn(*s.original, feats, &d2);
      for (std::size_t i = 0; i < d2.size(); ++i)
        s.original_feature[i] = !feats.empty() && d2[i] <= tol2;
    }
    s.original_ball = nearestIn(*s.original, *s.simplified);
    s.simplified_ball.resize(s.simplified->size());
    for (std::size_t i = 0; i < s.simplified_ball.size(); ++i)
      s.simplified_ball[i] = static_cast<std::int64_t>(i);
    std::size_t nf = 0;
    for (auto f : s.simplified_feature)
      nf += f;
    std::ostringstream os;
    os << s.original->size() << " -> " << s.simplified->size() << " points (" << nf << " features)";
    s.summary = os.str();
  }
  s.original_curvature = curvatureOf(*s.original, o.params.k_neighbors, s.original_shade);
  annotateSimplified(s);
  // Ramp up to the 95th percentile of |H|, so one spike does not flatten the picture.
  std::vector<double> finite;
  for (double h : s.original_curvature)
    if (std::isfinite(h))
      finite.push_back(h);
  if (!finite.empty())
  {
    const std::size_t k = finite.size() * 95 / 100;
    std::nth_element(finite.begin(), finite.begin() + static_cast<std::ptrdiff_t>(k), finite.end());
    s.curvature_hi = finite[k] > 0.0 ? finite[k] : 1.0;
  }
  if (!o.mesh.empty())
  {
    if (pcl::io::loadPolygonFile(o.mesh, s.mesh) <= 0 || s.mesh.polygons.empty())
      throw std::runtime_error(o.mesh + ": cannot read the mesh (PLY, OBJ, VTK, STL)");
    s.has_mesh = true;
  }
}

/// A copy of `src` coloured for `mode`; `feature` points get the feature colour when `mark`.
Cloud::Ptr coloured(const Cloud& src, ColourMode mode, const std::vector<double>& curvature,
                    const std::vector<float>& shade, const std::vector<std::int64_t>& ball,
                    const std::vector<std::uint8_t>& feature, bool has_rgb, double curvature_hi,
                    const Rgb& base, bool mark_features)
{
  auto out = std::make_shared<Cloud>(src);
  for (std::size_t i = 0; i < out->size(); ++i)
  {
    Rgb c = base;
    switch (mode)
    {
    case ColourMode::Label:
      for (int k = 0; k < 3; ++k)
        c[static_cast<std::size_t>(k)] = static_cast<std::uint8_t>(base[static_cast<std::size_t>(k)] * shade[i]);
      break;
    case ColourMode::Curvature: c = rampColour(curvature[i], 0.0, curvature_hi); break;
    case ColourMode::Ball: c = ball[i] >= 0 ? idColour(ball[i]) : kOriginalColour; break;
    case ColourMode::Input:
      c = has_rgb ? Rgb{src[i].r, src[i].g, src[i].b} : kOriginalColour;
      break;
    }
    if (mark_features && !feature.empty() && feature[i])
      c = kFeatureColour;
    (*out)[i].r = c[0];
    (*out)[i].g = c[1];
    (*out)[i].b = c[2];
  }
  return out;
}

struct App
{
  ViewerOptions opt;
  Scene scene;
  pcl::visualization::PCLVisualizer::Ptr vis;
  std::vector<int> ports;
  bool show_help = false;

  void addOrUpdate(const Cloud::Ptr& c, const std::string& id, int port, double size)
  {
    pcl::visualization::PointCloudColorHandlerRGBField<pcl::PointXYZRGB> rgb(c);
    if (!vis->updatePointCloud<pcl::PointXYZRGB>(c, rgb, id))
      vis->addPointCloud<pcl::PointXYZRGB>(c, rgb, id, port);
    vis->setPointCloudRenderingProperties(pcl::visualization::PCL_VISUALIZER_POINT_SIZE, size, id);
  }

  void text(const std::string& t, int x, int y, int size, const Rgb& c, const std::string& id, int port)
  {
    if (!vis->updateText(t, x, y, size, c[0] / 255.0, c[1] / 255.0, c[2] / 255.0, id))
      vis->addText(t, x, y, size, c[0] / 255.0, c[1] / 255.0, c[2] / 255.0, id, port);
  }

  void draw()
  {
    const Scene& s = scene;
    const ColourMode m = opt.colour;
    const double ps = opt.point_size;
    addOrUpdate(coloured(*s.original, m, s.original_curvature, s.original_shade, s.original_ball, s.original_feature, s.has_rgb,
                         s.curvature_hi, kOriginalColour, false),
                "original", ports[0], ps);
    addOrUpdate(coloured(*s.original, m, s.original_curvature, s.original_shade, s.original_ball, s.original_feature, s.has_rgb,
                         s.curvature_hi, kOriginalColour, false),
                "original2", ports[1], ps);
    // The features of the original, on top and larger.
    Cloud::Ptr feats(new Cloud);
    for (std::size_t i = 0; i < s.original->size(); ++i)
      if (s.original_feature[i])
      {
        pcl::PointXYZRGB p = (*s.original)[i];
        p.r = kFeatureColour[0];
        p.g = kFeatureColour[1];
        p.b = kFeatureColour[2];
        feats->push_back(p);
      }
    addOrUpdate(feats, "features", ports[1], ps + 2.0);
    addOrUpdate(coloured(*s.simplified, m, s.simplified_curvature, s.simplified_shade, s.simplified_ball, s.simplified_feature,
                         s.has_rgb, s.curvature_hi, kRepresentativeColour, true),
                "simplified", ports[2], ps + 1.0);
    const Rgb white = opt.dark_background ? Rgb{235, 235, 235} : Rgb{20, 20, 20};
    std::size_t nf = 0;
    for (auto f : s.original_feature)
      nf += f;
    text("original: " + std::to_string(s.original->size()) + " points", 10, opt.height - 30, 15, white, "t0", ports[0]);
    text("features: " + std::to_string(nf) + " points", 10, opt.height - 30, 15, white, "t1", ports[1]);
    text("simplified: " + std::to_string(s.simplified->size()) + " points", 10, opt.height - 30, 15, white, "t2", ports[2]);
    if (s.has_mesh)
      text("mesh: " + std::to_string(s.mesh.polygons.size()) + " faces", 10, opt.height - 30, 15, white, "t3", ports[3]);
    text(s.summary, 10, 26, 12, white, "summary", ports[0]);
    text(std::string("colour: ") + toString(m) + "   point size " + std::to_string(static_cast<int>(ps)),
         10, 8, 12, white, "mode", ports[0]);
    // Legend.
    text("# original", 10, 50, 13, kOriginalColour, "l0", ports[2]);
    text("# feature", 10, 32, 13, kFeatureColour, "l1", ports[2]);
    text("# representative", 10, 14, 13, kRepresentativeColour, "l2", ports[2]);
    text(show_help ? viewerKeyHelp() : std::string("h: keys"), 10, show_help ? 60 : 8, 12, white, "help", ports[1]);
    const double bg = opt.dark_background ? 0.08 : 0.95;
    for (int p : ports)
      vis->setBackgroundColor(bg, bg, bg, p);
  }

  void rerun()
  {
    if (!opt.simplified.empty())
    {
      std::cout << "pcl_ecs_viewer: T_err and alpha keys work in one-cloud mode only\n";
      return;
    }
    if (scene.original->size() > opt.interactive_limit)
    {
      std::cout << "pcl_ecs_viewer: cloud too large to re-run interactively\n";
      return;
    }
    const std::string why = validate(opt.params);
    if (!why.empty())
    {
      std::cout << "pcl_ecs_viewer: " << why << "\n";
      return;
    }
    runFilter(scene, opt.params);
    annotateSimplified(scene);
    std::cout << scene.summary << std::endl;
    vis->removePointCloud("simplified");
    draw();
  }

  void onKey(const pcl::visualization::KeyboardEvent& e)
  {
    if (!e.keyDown())
      return;
    // Some X servers report the lower-case key symbol with Shift held: upper-case it ourselves.
    std::string k = e.getKeySym();
    if (k.size() == 1 && e.isShiftPressed())
      k[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(k[0])));
    if (k == "h")
    {
      show_help = !show_help;
      std::cout << viewerKeyHelp();
    }
    else if (k == "m")
      opt.colour = nextColourMode(opt.colour);
    else if (k == "n")
      opt.point_size = std::min(20.0, opt.point_size + 1.0);
    else if (k == "N")
      opt.point_size = std::max(1.0, opt.point_size - 1.0);
    else if (k == "k")
      opt.dark_background = !opt.dark_background;
    else if (k == "t" || k == "T")
    {
      opt.params.error_threshold = std::min(0.5, k == "t" ? opt.params.error_threshold * 1.5 : opt.params.error_threshold / 1.5);
      rerun();
    }
    else if (k == "a" || k == "A")
    {
      opt.params.feature_factor = std::max(0.5, opt.params.feature_factor + (k == "a" ? 0.5 : -0.5));
      rerun();
    }
    else
      return;
    draw();
  }

  void build(bool interactive)
  {
    vis.reset(new pcl::visualization::PCLVisualizer("pcl_ecs_viewer", interactive));
    const int views = scene.has_mesh ? 4 : 3;
    ports.assign(static_cast<std::size_t>(views), 0);
    const auto rects = viewportLayout(views);
    for (int i = 0; i < views; ++i)
      vis->createViewPort(rects[static_cast<std::size_t>(i)][0], rects[static_cast<std::size_t>(i)][1],
                          rects[static_cast<std::size_t>(i)][2], rects[static_cast<std::size_t>(i)][3],
                          ports[static_cast<std::size_t>(i)]);
    vis->setSize(opt.width, opt.height);
    if (scene.has_mesh)
      vis->addPolygonMesh(scene.mesh, "mesh", ports[3]);
    draw();
    // One camera for every view.
    vtkRendererCollection* rens = vis->getRendererCollection();
    rens->InitTraversal();
    vtkRenderer* first = rens->GetNextItem();
    vtkCamera* cam = first->GetActiveCamera();
    for (vtkRenderer* r = rens->GetNextItem(); r; r = rens->GetNextItem())
      r->SetActiveCamera(cam);
    vis->resetCamera();
    // A three-quarter view reads better than looking straight down an axis.
    cam->Azimuth(30.0);
    cam->Elevation(20.0);
    cam->OrthogonalizeViewUp();
    vis->resetCamera();
    if (interactive)
      vis->registerKeyboardCallback([this](const pcl::visualization::KeyboardEvent& e) { onKey(e); });
  }
};

int run(int argc, char** argv)
{
  App app;
  try
  {
    app.opt = parseViewerArgs(std::vector<std::string>(argv + 1, argv + argc));
  }
  catch (const std::invalid_argument& e)
  {
    std::fprintf(stderr, "pcl_ecs_viewer: %s\n", e.what());
    return tools::kExitUsage;
  }
  if (app.opt.help)
  {
    std::cout << viewerUsage();
    return tools::kExitOk;
  }
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  if (!app.opt.screenshot.empty())
  {
    // Offscreen rendering with Debian's VTK still needs an X server: without a display, start a
    // virtual one (Xvfb) around ourselves, so a screenshot works on a headless machine.
    const char* display = std::getenv("DISPLAY");
    if ((!display || !*display) && !std::getenv("PCL_ECS_VIEWER_IN_XVFB"))
    {
      ::setenv("PCL_ECS_VIEWER_IN_XVFB", "1", 1);
      const std::string self = std::filesystem::read_symlink("/proc/self/exe").string();
      const std::string screen = "-screen 0 " + std::to_string(std::max(app.opt.width, 1920)) + "x" +
                                 std::to_string(std::max(app.opt.height, 1080)) + "x24";
      std::vector<std::string> args = {"xvfb-run", "-a", "-s", screen, self};
      args.insert(args.end(), argv + 1, argv + argc);
      std::vector<char*> cargs;
      for (auto& a : args)
        cargs.push_back(a.data());
      cargs.push_back(nullptr);
      ::execvp("xvfb-run", cargs.data());
      std::fprintf(stderr, "pcl_ecs_viewer: --screenshot needs an X display or xvfb-run (apt-get install xvfb)\n");
      return tools::kExitOutput;
    }
  }
  try
  {
    loadScene(app.scene, app.opt);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "pcl_ecs_viewer: %s\n", e.what());
    return tools::kExitInput;
  }
  std::cout << app.scene.summary << "\n";
  if (!app.opt.screenshot.empty())
  {
    const std::string why = io::checkWritable(app.opt.screenshot);
    if (!why.empty())
    {
      std::fprintf(stderr, "pcl_ecs_viewer: %s: %s\n", app.opt.screenshot.c_str(), why.c_str());
      return tools::kExitOutput;
    }
    app.build(false);
    app.vis->getRenderWindow()->SetOffScreenRendering(1);
    app.vis->getRenderWindow()->SetSize(app.opt.width, app.opt.height);
    app.vis->getRenderWindow()->Render();
    // Read the frame back and write it (to a temporary beside the target, renamed on success).
    vtkNew<vtkWindowToImageFilter> grab;
    grab->SetInput(app.vis->getRenderWindow());
    grab->SetInputBufferTypeToRGB();
    grab->ReadFrontBufferOff();
    grab->Update();
    io::AtomicOutput out(app.opt.screenshot);
    vtkNew<vtkPNGWriter> writer;
    writer->SetFileName(out.tempPath().c_str());
    writer->SetInputConnection(grab->GetOutputPort());
    writer->Write();
    if (writer->GetErrorCode() != 0)
    {
      std::fprintf(stderr, "pcl_ecs_viewer: %s: cannot write the PNG\n", app.opt.screenshot.c_str());
      return tools::kExitOutput;
    }
    out.commit();
    return tools::kExitOk;
  }
  app.build(true);
  app.vis->spin();
  return tools::kExitOk;
}

}  // namespace

int main(int argc, char** argv)
{
  try
  {
    return run(argc, argv);
  }
  catch (const std::exception& e)
  {
    std::fprintf(stderr, "pcl_ecs_viewer: internal error: %s\n", e.what());
    return tools::kExitInternal;
  }
}
