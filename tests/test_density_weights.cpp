#include <pcl_ecs/stages/density_weights.h>

#include "synthetic_shapes.h"
#include "test_support.h"

#include <gtest/gtest.h>

using namespace pcl_ecs_test;

// On a square grid of spacing h an interior point's 4 nearest neighbours are at h and the next 4
// at h·√2, so eq. 1 gives exactly h² for K = 4 and (4h² + 4·2h²)/8 = 1.5h² for K = 8.
TEST(DensityWeights, ExactOnAGrid)
{
  const double h = 0.25;
  const int n = 9;
  auto cloud = gridPlane(n, h);
  for (int k : {4, 8})
  {
    std::vector<double> w;
    pcl_ecs::computeDensityWeights(*cloud, makeTable(cloud, k), w);
    ASSERT_EQ(w.size(), cloud->size());
    const double expected = k == 4 ? h * h : 1.5 * h * h;
    for (int i = 1; i < n - 1; ++i)
      for (int j = 1; j < n - 1; ++j)
        EXPECT_NEAR(w[static_cast<std::size_t>(i * n + j)], expected, 1e-7) << i << "," << j;
  }
}

TEST(DensityWeights, DenserRegionsGetSmallerWeights)
{
  auto sparse = gridPlane(10, 0.2), dense = gridPlane(10, 0.1);
  std::vector<double> ws, wd;
  pcl_ecs::computeDensityWeights(*sparse, makeTable(sparse, 8), ws);
  pcl_ecs::computeDensityWeights(*dense, makeTable(dense, 8), wd);
  EXPECT_NEAR(wd[55] * 4.0, ws[55], 1e-7);  // weight scales with spacing squared
}
