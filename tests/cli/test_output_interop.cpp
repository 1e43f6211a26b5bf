// What other tools read of our outputs: for every point type the filter supports and every output
// encoding, PCL's own loaders (loadPCDFile / loadPLYFile, typed and untyped) and pcl_pcd2ply read
// what pcd_simplify writes, with every value equal to what was meant; the output's records are
// the input's (names, types, every field; a representative's attributes those of its source
// point); centimetre UTM coordinates come out exact.
#include "cli_fixture.h"
#include "common/cloud_simplify.h"

#include <pcl_ecs/io/cloud_convert.h>
#include <pcl_ecs/io/cloud_io.h>

#include <cmath>
#include <cstring>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <tuple>

#include <gtest/gtest.h>
#include <pcl/common/io.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

namespace
{
using pcl_ecs::io::Encoding;
using pcl_ecs::io::Format;
const std::string kTool = PCD_SIMPLIFY_PATH;
const std::string kPcd2Ply = PCL_PCD2PLY_PATH;

/// A noisy sphere of `PointT` whose every attribute field holds random values (normals random unit
/// vectors, colours random with full alpha), as PCL lays the type out (padding included).
template <typename PointT>
pcl::PCLPointCloud2 makeInput(int n, std::uint32_t seed)
{
  pcl::PointCloud<PointT> cloud;
  cloud.resize(static_cast<std::size_t>(n));
  pcl::PCLPointCloud2 blob;
  pcl::toPCLPointCloud2(cloud, blob);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i)
  {
    std::uint8_t* rec = blob.data.data() + static_cast<std::size_t>(i) * blob.point_step;
    const double z = 1.0 - 2.0 * (i + 0.5) / n, r = std::sqrt(1.0 - z * z), t = golden * i;
    const float rho = 1.0f + 0.002f * u(rng);
    Eigen::Vector3f nrm(u(rng), u(rng), u(rng));
    nrm.normalize();
    for (const auto& f : blob.fields)
    {
      std::uint8_t* at = rec + f.offset;
      float v = 0.0f;
      if (f.name == "x") v = rho * static_cast<float>(r * std::cos(t));
      else if (f.name == "y") v = rho * static_cast<float>(r * std::sin(t));
      else if (f.name == "z") v = rho * static_cast<float>(z);
      else if (f.name == "normal_x") v = nrm.x();
      else if (f.name == "normal_y") v = nrm.y();
      else if (f.name == "normal_z") v = nrm.z();
      else if (f.name == "rgb" || f.name == "rgba")
      {
        const std::uint32_t c = (rng() & 0xFFFFFFu) | 0xFF000000u;
        std::memcpy(at, &c, 4);
        continue;
      }
      else if (f.name == "label")
      {
        const std::uint32_t l = rng() % 100000u;
        std::memcpy(at, &l, 4);
        continue;
      }
      else if (f.name == "intensity" || f.name == "curvature") v = 1000.0f * std::abs(u(rng));
      else
        continue;
      std::memcpy(at, &v, 4);
    }
  }
  return blob;
}

/// Field names of a layout, in order.
std::vector<std::string> names(const std::vector<pcl::PCLPointField>& fields)
{
  std::vector<std::string> out;
  for (const auto& f : fields)
    out.push_back(f.name);
  return out;
}

/// The bytes of every field of PointT (padding left out) of points a and b are equal; with
/// `rgb_only`, a colour field `rgb` is compared on its r, g, b bytes (PLY has no alpha for it, and
/// PCL's PLY reader leaves alpha 0).
template <typename PointT>
void expectSamePoints(const pcl::PointCloud<PointT>& got, const pcl::PointCloud<PointT>& want, const std::string& what,
                      bool rgb_only = false)
{
  ASSERT_EQ(got.size(), want.size()) << what;
  const auto fields = pcl::getFields<PointT>();
  for (std::size_t i = 0; i < got.size(); ++i)
    for (const auto& f : fields)
    {
      const std::size_t bytes = static_cast<std::size_t>(pcl::getFieldSize(f.datatype)) * f.count;
      const auto* a = reinterpret_cast<const std::uint8_t*>(&got[i]) + f.offset;
      const auto* b = reinterpret_cast<const std::uint8_t*>(&want[i]) + f.offset;
      const std::size_t compared = rgb_only && f.name == "rgb" ? 3 : bytes;  // little-endian b g r
      if (std::memcmp(a, b, compared) != 0)
      {
        ADD_FAILURE() << what << ": point " << i << " field " << f.name << " differs";
        return;
      }
    }
}

template <typename PointT>
class Interop : public pcl_ecs_test::TempDirTest
{
};

using PointTypes = ::testing::Types<pcl::PointXYZ, pcl::PointXYZI, pcl::PointXYZL, pcl::PointXYZRGB, pcl::PointXYZRGBA,
                                    pcl::PointXYZRGBL, pcl::PointNormal, pcl::PointXYZRGBNormal, pcl::PointXYZINormal>;
TYPED_TEST_SUITE(Interop, PointTypes);

TYPED_TEST(Interop, OutputsAreTheInputsRecordsAndPclReadsEveryEncoding)
{
  using PointT = TypeParam;
  // The input as PCL writes it (with its padding fields), read by our reader.
  pcl::PointCloud<PointT> pcl_cloud;
  pcl::fromPCLPointCloud2(makeInput<PointT>(4000, 7), pcl_cloud);
  const std::string in_path = this->path("in.pcd");
  ASSERT_EQ(pcl::io::savePCDFileBinary(in_path, pcl_cloud), 0);
  pcl::PCLPointCloud2 input;
  pcl_ecs::io::readCloud(in_path, input);

  pcl_ecs::tools::CloudRunOptions options;
  options.features = true;
  const pcl_ecs::tools::CloudRun run = pcl_ecs::tools::simplifyCloud(input, pcl_ecs::Parameters{}, options);
  ASSERT_TRUE(run.result.error.empty()) << run.result.error;
  const pcl::PCLPointCloud2& out = run.output;
  const std::size_t m = out.width;
  ASSERT_GT(m, 10u);
  ASSERT_LT(m, 4000u);

  // Packed records of the input's own fields, with their names: no '_', no gap.
  std::vector<pcl::PCLPointField> packed;
  const std::uint32_t step = pcl_ecs::io::packedFields(input.fields, packed);
  EXPECT_EQ(names(out.fields), names(packed));
  EXPECT_EQ(out.point_step, step);
  for (const auto& f : out.fields)
    EXPECT_NE(f.name, "_");

  // Every attribute is the source point's; a feature's coordinates too, a representative's are its
  // optimised point (float, as the input's).
  const int fx = pcl_ecs::io::fieldIndex(out.fields, "x");
  for (std::size_t i = 0; i < m; ++i)
  {
    const auto src = static_cast<std::size_t>(run.result.source_index[i]);
    for (const auto& f : out.fields)
    {
      const int k = pcl_ecs::io::fieldIndex(input.fields, f.name);
      ASSERT_GE(k, 0);
      const bool coordinate = f.name == "x" || f.name == "y" || f.name == "z";
      if (coordinate && run.result.labels[i] == pcl_ecs::PointLabel::Representative)
        continue;
      ASSERT_EQ(std::memcmp(out.data.data() + i * out.point_step + f.offset,
                            input.data.data() + src * input.point_step + input.fields[static_cast<std::size_t>(k)].offset,
                            pcl::getFieldSize(f.datatype) * f.count),
                0)
          << "point " << i << " field " << f.name;
    }
    if (run.result.labels[i] == pcl_ecs::PointLabel::Representative)
    {
      const auto& v = run.result.balls[static_cast<std::size_t>(run.result.ball_of_output[i])].representative;
      float x;
      std::memcpy(&x, out.data.data() + i * out.point_step + out.fields[static_cast<std::size_t>(fx)].offset, 4);
      EXPECT_EQ(x, static_cast<float>(v.x()));
    }
  }

  pcl::PointCloud<PointT> expected;
  pcl_ecs::io::fromCloud(out, expected);
  const std::tuple<const char*, Format, Encoding> encodings[] = {
      {"out_binary.pcd", Format::Pcd, Encoding::Binary},
      {"out_ascii.pcd", Format::Pcd, Encoding::Ascii},
      {"out_compressed.pcd", Format::Pcd, Encoding::BinaryCompressed},
      {"out_binary.ply", Format::Ply, Encoding::Binary},
      {"out_ascii.ply", Format::Ply, Encoding::Ascii}};
  for (const auto& [name, format, encoding] : encodings)
  {
    const std::string p = this->path(name);
    pcl_ecs::io::writeCloud(p, format, out, encoding);
    pcl::PointCloud<PointT> typed;
    if (format == Format::Pcd)
    {
      pcl::PCLPointCloud2 back;
      ASSERT_EQ(pcl::io::loadPCDFile(p, back), 0) << name;
      EXPECT_EQ(names(back.fields), names(out.fields)) << name;
      for (const auto& f : back.fields)
        EXPECT_GE(f.count, 1u) << name << " field " << f.name;
      ASSERT_EQ(pcl::io::loadPCDFile<PointT>(p, typed), 0) << name;
      expectSamePoints(typed, expected, name);
      // pcl-tools' converter, which aborted on padding fields.
      const std::string ply = this->path(std::string(name) + ".ply");
      const auto conv = pcl_ecs_test::runCommand("timeout 60 " + kPcd2Ply + " " + p + " " + ply, this->dir_);
      EXPECT_EQ(conv.code, 0) << name << ": " << conv.out << conv.err;
      EXPECT_NE(pcl_ecs_test::slurp(ply).find("element vertex " + std::to_string(m) + "\n"), std::string::npos) << name;
    }
    else
    {
      ASSERT_EQ(pcl::io::loadPLYFile<PointT>(p, typed), 0) << name;
      expectSamePoints(typed, expected, name, pcl_ecs::io::fieldIndex(out.fields, "rgb") >= 0);
    }
  }
}

// Centimetre UTM coordinates: kept as double from every format that can hold them, features equal
// to their input point, representatives where the method put them.
class Utm : public pcl_ecs_test::TempDirTest
{
protected:
  /// A gently curved 100 m × 100 m patch at UTM coordinates, rounded to the centimetre.
  std::vector<Eigen::Vector3d> patch() const
  {
    std::vector<Eigen::Vector3d> pts;
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(0.0, 100.0);
    for (int i = 0; i < 6000; ++i)
    {
      const double e = u(rng), nn = u(rng);
      const double h = 120.0 + 3.0 * std::sin(e / 15.0) * std::cos(nn / 20.0) + (e > 60.0 ? 2.0 : 0.0);
      pts.emplace_back(std::round((512300.0 + e) * 100.0) / 100.0, std::round((5412800.0 + nn) * 100.0) / 100.0,
                       std::round(h * 100.0) / 100.0);
    }
    return pts;
  }
};

TEST_F(Utm, CentimetreCoordinatesStayExactThroughXyzPlyAndPcd)
{
  const auto pts = patch();
  std::set<std::tuple<double, double, double>> inputs;
  for (const auto& p : pts)
    inputs.insert({p.x(), p.y(), p.z()});
  // The same points as XYZ text, double PLY and double PCD.
  {
    std::ofstream xyz(path("utm.xyz"));
    xyz.precision(12);
    for (const auto& p : pts)
      xyz << p.x() << ' ' << p.y() << ' ' << p.z() << '\n';
  }
  pcl::PCLPointCloud2 blob;
  blob.height = 1;
  blob.width = static_cast<std::uint32_t>(pts.size());
  for (const char* a : {"x", "y", "z"})
  {
    pcl::PCLPointField f;
    f.name = a;
    f.offset = blob.point_step;
    f.datatype = pcl::PCLPointField::FLOAT64;
    f.count = 1;
    blob.fields.push_back(f);
    blob.point_step += 8;
  }
  blob.data.resize(pts.size() * 24);
  std::memcpy(blob.data.data(), pts.data(), pts.size() * 24);
  pcl_ecs::io::writeCloud(path("utm.ply"), Format::Ply, blob, Encoding::Binary);
  pcl_ecs::io::writeCloud(path("utm.pcd"), Format::Pcd, blob, Encoding::Binary);

  for (const std::string in : {"utm.xyz", "utm.ply", "utm.pcd"})
    for (const std::string out : {"out.pcd", "out.ply", "out_ascii.pcd"})
    {
      const std::string what = in + " -> " + out;
      const auto r = runTool(kTool, path(in) + " " + path(out) + " --labels --quiet" +
                                        (out == "out_ascii.pcd" ? " --ascii" : ""));
      ASSERT_EQ(r.code, 0) << what << ": " << r.err;
      pcl::PCLPointCloud2 back;
      pcl_ecs::io::readCloud(path(out), back);
      const int fx = pcl_ecs::io::fieldIndex(back.fields, "x"), fy = pcl_ecs::io::fieldIndex(back.fields, "y"),
                fz = pcl_ecs::io::fieldIndex(back.fields, "z"), fl = pcl_ecs::io::fieldIndex(back.fields, "ecs_label");
      ASSERT_TRUE(fx >= 0 && fy >= 0 && fz >= 0 && fl >= 0) << what;
      for (int k : {fx, fy, fz})
        EXPECT_EQ(back.fields[static_cast<std::size_t>(k)].datatype, pcl::PCLPointField::FLOAT64) << what;

      // The in-process run on the same input: the file holds exactly its points.
      pcl::PCLPointCloud2 input;
      pcl_ecs::io::readCloud(path(in), input);
      const pcl_ecs::tools::CloudRun run = pcl_ecs::tools::simplifyCloud(input, pcl_ecs::Parameters{}, {});
      ASSERT_TRUE(run.result.error.empty());
      ASSERT_EQ(back.width, run.result.labels.size()) << what;
      const double L = run.result.summary.bbox_diagonal;
      std::size_t features = 0;
      for (std::size_t i = 0; i < back.width; ++i)
      {
        const std::uint8_t* rec = back.data.data() + i * back.point_step;
        double v[3];
        for (int a = 0; a < 3; ++a)
          std::memcpy(&v[a], rec + back.fields[static_cast<std::size_t>(a == 0 ? fx : a == 1 ? fy : fz)].offset, 8);
        if (rec[back.fields[static_cast<std::size_t>(fl)].offset] == 1)
        {
          ++features;
          EXPECT_TRUE(inputs.count({v[0], v[1], v[2]})) << what << ": feature " << i << " is not an input point";
        }
        else
        {
          const auto& want = run.result.balls[static_cast<std::size_t>(run.result.ball_of_output[i])].representative;
          for (int a = 0; a < 3; ++a)
            EXPECT_LE(std::abs(v[a] - want[a]), 1e-6 * L) << what << ": representative " << i;
        }
      }
      EXPECT_GT(features, 0u) << what << ": the step at e = 60 m should give feature points";
    }
}

}  // namespace
