// cover_fixture.h: a cover run on a synthetic cloud with every input of the cover computed by the
// stages (tests of ball_cover and gap_fill).
#pragma once

#include <pcl_ecs/simplify_core.h>
#include <pcl_ecs/stages/ball_cover.h>
#include <pcl_ecs/stages/density_weights.h>
#include <pcl_ecs/stages/feature_measure.h>
#include <pcl_ecs/stages/global_stats.h>
#include <pcl_ecs/stages/local_density.h>
#include <pcl_ecs/stages/paraboloid_curvature.h>

#include "synthetic_shapes.h"
#include "test_support.h"

#include <pcl/search/kdtree.h>

namespace pcl_ecs_test
{
struct CoverRun
{
  CoverRun(const Cloud::Ptr& cloud, const pcl_ecs::Parameters& params, double terr,
           std::vector<std::uint8_t> is_feature = {})
    : cloud_(cloud)
  {
    const auto table = makeTable(cloud, params.k_neighbors);
    normals = makeNormals(cloud, table);
    pcl_ecs::computeDensityWeights(*cloud, table, weights);
    feature = is_feature.empty() ? std::vector<std::uint8_t>(cloud->size(), 0) : std::move(is_feature);
    tree.setInputCloud(cloud);
    pcl_ecs::computeLocalDensity(*cloud, table, feature, tree, 2, density);
    pcl_ecs::computeMeanCurvature(*cloud, normals, table, feature, 2, curvature);
    pcl_ecs::computeFeatureMeasure(*cloud, normals, table, 2, measure);
    pcl_ecs::coverWithBalls(input(), params, terr, out);
  }
  /// The means the method takes (the same GlobalStats as the filter and the tiled run).
  pcl_ecs::GlobalStats stats() const
  {
    pcl_ecs::GlobalStats s;
    s.addMeasures(measure);
    s.addNonFeatures(density, weights, curvature, feature);
    return s;
  }
  pcl_ecs::CoverInput input() const
  {
    return pcl_ecs::makeCoverInput(*cloud_, normals, weights, feature, curvature, density, stats(),
                                   pcl_ecs::boundingBoxDiagonal(*cloud_), tree);
  }
  Cloud::Ptr cloud_;
  pcl_ecs::NormalList normals;
  std::vector<double> weights, density, curvature, measure;
  std::vector<std::uint8_t> feature;
  pcl::search::KdTree<pcl::PointXYZ> tree;
  pcl_ecs::CoverOutput out;
};
}  // namespace pcl_ecs_test
