// The filter for every point type we ship: attributes of a representative come from a real input
// point, normals are unit length, and input normals are used when asked.
#include <pcl_ecs/feature_aware_cover_simplify.h>

#include "synthetic_shapes.h"

#include <gtest/gtest.h>
#include <pcl/type_traits.h>

using namespace pcl_ecs_test;

namespace
{
/// A sphere of 8000 points of type PointT, each with distinct attributes derived from its index
/// and, for types with normals, the exact outward normal.
template <typename PointT>
typename pcl::PointCloud<PointT>::Ptr attributedSphere()
{
  const auto xyz = fibonacciSphere(8000, 1.0);
  auto c = std::make_shared<pcl::PointCloud<PointT>>();
  for (std::size_t i = 0; i < xyz->size(); ++i)
  {
    PointT p;
    p.x = (*xyz)[i].x;
    p.y = (*xyz)[i].y;
    p.z = (*xyz)[i].z;
    if constexpr (pcl::traits::has_color_v<PointT>)
    {
      p.r = static_cast<std::uint8_t>(i % 251);
      p.g = static_cast<std::uint8_t>((i / 251) % 251);
      p.b = static_cast<std::uint8_t>(i % 7);
    }
    if constexpr (pcl::traits::has_intensity_v<PointT>)
      p.intensity = static_cast<float>(i);
    if constexpr (pcl::traits::has_label_v<PointT>)
      p.label = static_cast<std::uint32_t>(i * 3);
    if constexpr (pcl::traits::has_normal_v<PointT>)
    {
      const Eigen::Vector3f n = p.getVector3fMap().normalized();
      p.normal_x = n.x();
      p.normal_y = n.y();
      p.normal_z = n.z();
    }
    c->push_back(p);
  }
  return c;
}
}  // namespace

template <typename PointT>
class PointTypes : public ::testing::Test
{
};
using Types = ::testing::Types<pcl::PointXYZ, pcl::PointXYZI, pcl::PointXYZL, pcl::PointXYZRGB,
                               pcl::PointXYZRGBA, pcl::PointXYZRGBL, pcl::PointNormal,
                               pcl::PointXYZRGBNormal, pcl::PointXYZINormal>;
TYPED_TEST_SUITE(PointTypes, Types);

TYPED_TEST(PointTypes, AttributesComeFromRealInputPoints)
{
  using PointT = TypeParam;
  const auto cloud = attributedSphere<PointT>();
  pcl_ecs::FeatureAwareCoverSimplify<PointT> f;
  f.setInputCloud(cloud);
  pcl::PointCloud<PointT> out;
  f.filter(out);
  ASSERT_GT(out.size(), 50u);
  ASSERT_LT(out.size(), cloud->size() / 4);
  const auto& r = f.getResult();
  for (std::size_t o = 0; o < out.size(); ++o)
  {
    const PointT& src = (*cloud)[static_cast<std::size_t>(r.source_index[o])];
    const PointT& p = out[o];
    if constexpr (pcl::traits::has_color_v<PointT>)
      EXPECT_EQ(p.rgba, src.rgba);
    if constexpr (pcl::traits::has_intensity_v<PointT>)
      EXPECT_EQ(p.intensity, src.intensity);
    if constexpr (pcl::traits::has_label_v<PointT>)
      EXPECT_EQ(p.label, src.label);
    if constexpr (pcl::traits::has_normal_v<PointT>)
    {
      const Eigen::Vector3f n(p.normal_x, p.normal_y, p.normal_z);
      EXPECT_NEAR(n.norm(), 1.0f, 1e-5f);
      // Estimated normals are oriented towards the sensor origin (the sphere's centre here).
      EXPECT_LT(n.dot(p.getVector3fMap()), 0.0f);
    }
    // The attribute source is a member of the ball: near the representative.
    EXPECT_LT((p.getVector3fMap() - src.getVector3fMap()).norm(), 0.1f);
  }
}

// With exact input normals the estimated ones are not needed: the output carries normals close to
// the true radial direction, oriented as given (outwards).
TEST(PointTypesNormals, InputNormalsAreUsedWhenAsked)
{
  const auto cloud = attributedSphere<pcl::PointNormal>();
  pcl_ecs::FeatureAwareCoverSimplify<pcl::PointNormal> f;
  f.setUseInputNormals(true);
  f.setInputCloud(cloud);
  pcl::PointCloud<pcl::PointNormal> out;
  f.filter(out);
  ASSERT_GT(out.size(), 50u);
  for (const auto& p : out)
  {
    const Eigen::Vector3f n(p.normal_x, p.normal_y, p.normal_z);
    EXPECT_GT(n.dot(p.getVector3fMap().normalized()), 0.99f);
  }
  // Non-finite input normals are skipped like non-finite points.
  auto broken = std::make_shared<pcl::PointCloud<pcl::PointNormal>>(*cloud);
  (*broken)[5].normal_x = std::numeric_limits<float>::quiet_NaN();
  f.setInputCloud(broken);
  f.filter(out);
  EXPECT_EQ(f.getResult().summary.finite_points, cloud->size() - 1);
  EXPECT_EQ(f.getResult().input_to_output[5], -1);
}
