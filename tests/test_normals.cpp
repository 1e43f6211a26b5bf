#include <pcl_ecs/stages/normals.h>

#include "synthetic_shapes.h"
#include "test_support.h"

#include <gtest/gtest.h>

using namespace pcl_ecs_test;

TEST(Normals, PlaneNormalsAreTheAxis)
{
  auto cloud = randomPlane(2000, 1.0, 4);
  const auto normals = makeNormals(cloud, makeTable(cloud, 16));
  for (const auto& n : normals)
  {
    EXPECT_NEAR(std::abs(n.z()), 1.0f, 1e-6f);
    EXPECT_NEAR(n.norm(), 1.0f, 1e-6f);
  }
}

TEST(Normals, SphereNormalsAreRadial)
{
  auto cloud = fibonacciSphere(20000, 1.0);
  const auto normals = makeNormals(cloud, makeTable(cloud, 16));
  for (std::size_t i = 0; i < cloud->size(); ++i)
  {
    const Eigen::Vector3f radial = (*cloud)[i].getVector3fMap().normalized();
    // 16 neighbours span ~0.03 rad of the sphere: the PCA normal is radial to ~1e-4.
    EXPECT_GT(std::abs(radial.dot(normals[i])), 1.0f - 1e-4f);
  }
}

TEST(Normals, IdenticalPointsGetADefaultUnitNormal)
{
  auto cloud = std::make_shared<Cloud>();
  for (int i = 0; i < 20; ++i)
    cloud->push_back(pcl::PointXYZ(1, 1, 1));
  const auto normals = makeNormals(cloud, makeTable(cloud, 8));
  for (const auto& n : normals)
    EXPECT_FLOAT_EQ(n.norm(), 1.0f);
}

TEST(Normals, InputNormalsAreValidatedAndNormalised)
{
  pcl_ecs::NormalList n = {Eigen::Vector3f(0, 0, 2), Eigen::Vector3f(3, 4, 0)};
  std::size_t bad = 99;
  EXPECT_EQ(pcl_ecs::normalizeInputNormals(n, bad), pcl_ecs::Status::Ok);
  EXPECT_FLOAT_EQ(n[0].z(), 1.0f);
  EXPECT_FLOAT_EQ(n[1].x(), 0.6f);
  n.push_back(Eigen::Vector3f::Zero());
  EXPECT_EQ(pcl_ecs::normalizeInputNormals(n, bad), pcl_ecs::Status::BadNormals);
  EXPECT_EQ(bad, 2u);
  n.back() = Eigen::Vector3f(NAN, 0, 1);
  EXPECT_EQ(pcl_ecs::normalizeInputNormals(n, bad), pcl_ecs::Status::BadNormals);
}
