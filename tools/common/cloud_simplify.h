// cloud_simplify.h — the method on a cloud as the tools read it (a PCLPointCloud2 of any fields
// and types), shared by pcd_simplify and ecs_node.
//
// The filter runs on the coordinates alone (plus the input's normals with use_input_normals), in
// a frame centred on the cloud so that float keeps them precise. The output is then made of the
// input's own records: a feature point is its input record unchanged (coordinates, normal, colour,
// every field, bit for bit); a representative is the record of its source point (Result::
// source_index) with x, y, z replaced by the optimised point, stored in the input's coordinate
// type (double stays double). So every field and its name travel through, and a representative's
// normal, colour and intensity are those of the input point it stands on.
#pragma once

#include <pcl_ecs/parameters.h>
#include <pcl_ecs/result.h>
#include <pcl_ecs/simplify_core.h>

#include <nlohmann/json.hpp>
#include <pcl/PCLPointCloud2.h>

namespace pcl_ecs
{
namespace tools
{

struct CloudRun
{
  pcl::PCLPointCloud2 output;    ///< packed records of the input's fields (+ ecs_label)
  pcl::PCLPointCloud2 features;  ///< the feature points alone (when asked for)
  Result result;                 ///< balls' centres and representatives in the input's frame
};

struct CloudRunOptions
{
  double target_ratio = 0.0;  ///< > 0: target size = ratio × the distinct finite input points
  bool features = false;      ///< fill CloudRun::features
  bool labels = false;        ///< append a UINT8 field ecs_label (1 feature, 2 representative)
  bool radii = false;         ///< append a FLOAT32 field ecs_radius (pointRadii: 0 for a feature point)
  ProgressCallback progress;
};

/** \brief Simplify `input`. On failure the result's `error` says why and the clouds are empty. */
CloudRun simplifyCloud(const pcl::PCLPointCloud2& input, const Parameters& params, const CloudRunOptions& options);

/** \brief What a run used and found, as `pcd_simplify --stats` writes it (and the Python
 * package's Result.summary): parameters, counts, target, geometry and timings. */
/// Every parameter of `p` under its one spelling (parameter_table.h): {"terr": 0.001, ...}.
nlohmann::json parametersJson(const Parameters& p);

nlohmann::json runStatsJson(const Summary& s, const Parameters& p, double target_ratio);

/** \brief Finite points of `cloud` at distinct places (coincident points count once). */
std::size_t distinctFinitePoints(const pcl::PCLPointCloud2& cloud);

}  // namespace tools
}  // namespace pcl_ecs
