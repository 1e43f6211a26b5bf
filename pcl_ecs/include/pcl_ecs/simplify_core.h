// simplify_core.h — the whole method on plain values: local-frame points in, features, balls and
// timings out. The pcl::Filter (feature_aware_cover_simplify.h) converts to and from point types;
// the streaming path and the tools reach the method through the filter.
#pragma once

#include <pcl_ecs/parameters.h>
#include <pcl_ecs/result.h>
#include <pcl_ecs/stages/ball_cover.h>
#include <pcl_ecs/types.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace pcl_ecs
{

/** \brief Progress callback: a stage name and a fraction in [0, 1]. Shared by every front end. */
using ProgressCallback = std::function<void(const char* stage, double fraction)>;

/** \brief Everything the method computes, in local-frame units. */
struct CoreOutput
{
  NormalList normals;                   ///< eq. 2 (or the input's, normalised)
  std::vector<double> weights;          ///< eq. 1
  std::vector<double> measure;          ///< eq. 3
  std::vector<std::uint8_t> is_feature; ///< eq. 4
  /// with feature thinning (a target size, or Parameters::feature_spacing; stages/feature_thinning.h):
  /// for a feature point, the kept feature point standing for it (itself when kept); empty when
  /// every feature point is kept
  std::vector<std::int64_t> feature_kept_by;
  std::vector<double> density;          ///< eq. 5
  std::vector<double> curvature;        ///< eq. 11
  CoverOutput cover;                    ///< steps 2-7
  Summary summary;                      ///< counts, δ, means, T_err used, timings
  std::string error;                    ///< why the run failed (empty on success)

  /// The feature point whose output stands for feature point i (i itself unless thinned out).
  std::size_t keptFeature(std::size_t i) const
  {
    return feature_kept_by.empty() ? i : static_cast<std::size_t>(feature_kept_by[i]);
  }
};

/** \brief Run the method on `cloud` (finite points, local frame).
 * \param[in] cloud          the points (at least k_neighbors + 1, not all on a line)
 * \param[in] input_normals  the input's normals when params.use_input_normals, else nullptr
 * \param[in] params         validated parameters
 * \param[in] progress       optional progress callback
 * \param[out] out           what was computed; out.error says why when the status is not Ok */
Status simplifyLocal(const LocalCloud::ConstPtr& cloud, const NormalList* input_normals,
                     const Parameters& params, const ProgressCallback& progress, CoreOutput& out);

/** \brief `n` turned towards `viewpoint` as seen from `at` (one frame for both), as PCL's
 * NormalEstimation orients normals: flipped when (viewpoint − at) · n < 0. */
inline Eigen::Vector3f orientTowards(const Eigen::Vector3f& n, const Eigen::Vector3d& at, const Eigen::Vector3d& viewpoint)
{
  return (viewpoint - at).dot(n.cast<double>()) < 0.0 ? Eigen::Vector3f(-n) : n;
}

/** \brief Diagonal of the axis-aligned bounding box of `cloud`. */
double boundingBoxDiagonal(const LocalCloud& cloud);

/** \brief The factor that brings a cloud of largest extent `extent` into float's comfortable
 * range for the local frame: 1 for extents in [2^-20, 2^20] (everyday units, left as they are),
 * otherwise the power of four that puts the extent in [0.5, 2). A power of four scales every
 * length, square and square root exactly. */
double frameScale(double extent);

/** \brief Give the lengths of a summary computed in a frame scaled by `scale` back in the input's
 * units (δ, spacing, neighbourhood radius, diagonal, gap bound; curvature inversely). */
void unscaleSummary(Summary& summary, double scale);

}  // namespace pcl_ecs
