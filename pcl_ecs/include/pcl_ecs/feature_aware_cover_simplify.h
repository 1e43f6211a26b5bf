// feature_aware_cover_simplify.h — the paper's whole method as a drop-in pcl::Filter.
//
//   pcl_ecs::FeatureAwareCoverSimplify<pcl::PointXYZ> ecs;   // where pcl::VoxelGrid stood
//   ecs.setInputCloud(cloud);
//   ecs.setErrorThreshold(1e-3);   // T_err, a fraction of the bounding-box diagonal
//   ecs.setFeatureFactor(6.0);     // α
//   ecs.filter(*simplified);
//   const pcl_ecs::Result& r = ecs.getResult();  // labels, balls, mapping, timings
#pragma once

#include <pcl_ecs/parameters.h>
#include <pcl_ecs/result.h>
#include <pcl_ecs/simplify_core.h>

#include <pcl/filters/filter.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace pcl_ecs
{

/** \brief Feature-preserving, error-controllable simplification (the paper's method) as a
 * pcl::Filter: feature points (eq. 3-4) are kept as they are; every other region is covered by
 * balls as large as the quadric error bound T_err allows (eq. 13-15), each replaced by one
 * optimised point. Representatives are new points, so this derives from pcl::Filter, not
 * pcl::FilterIndices.
 *
 * Contract (as pcl::VoxelGrid): honours setIndices; skips non-finite points; the output is
 * unorganised (height 1), dense, with the input's header; on any error the output is cleared and
 * PCL_ERROR says why. Feature points come first in the output, in input order, then one
 * representative per ball in the order the balls were made.
 */
template <typename PointT>
class FeatureAwareCoverSimplify : public pcl::Filter<PointT>
{
public:
  using Ptr = std::shared_ptr<FeatureAwareCoverSimplify<PointT>>;
  using ConstPtr = std::shared_ptr<const FeatureAwareCoverSimplify<PointT>>;
  using PointCloud = typename pcl::Filter<PointT>::PointCloud;

  /** \brief A filter with the documented defaults (Parameters). */
  FeatureAwareCoverSimplify() { this->filter_name_ = "FeatureAwareCoverSimplify"; }

  /** \brief Set all parameters at once (validated when filter() runs). */
  void setParameters(const Parameters& params) { params_ = params; }
  /** \brief All parameters. */
  const Parameters& getParameters() const { return params_; }

  /** \brief T_err, as a fraction of the bounding-box diagonal L; in (0, 1). Default 1e-3. */
  void setErrorThreshold(double t_err) { params_.error_threshold = t_err; }
  double getErrorThreshold() const { return params_.error_threshold; }

  /** \brief α of eq. 4 (> 0): larger keeps fewer feature points. Default 6. */
  void setFeatureFactor(double alpha) { params_.feature_factor = alpha; }
  double getFeatureFactor() const { return params_.feature_factor; }

  /** \brief K, the neighbourhood size of eq. 1, 2, 3, 7-12; in [5, 200]. Default 16. */
  void setNeighborhoodSize(int k) { params_.k_neighbors = k; }
  int getNeighborhoodSize() const { return params_.k_neighbors; }

  /** \brief The error form of E(r) (eq. 14). Default ErrorForm::Normalized. */
  void setErrorForm(ErrorForm form) { params_.error_form = form; }
  ErrorForm getErrorForm() const { return params_.error_form; }

  /** \brief Step 5 on or off. Default on. */
  void setAdaptiveTolerance(bool on) { params_.adaptive = on; }
  bool getAdaptiveTolerance() const { return params_.adaptive; }

  /** \brief Step 5's factor, in [1, 100]. Default 2. */
  void setAdaptiveFactor(double factor) { params_.adaptive_factor = factor; }
  double getAdaptiveFactor() const { return params_.adaptive_factor; }

  /** \brief Radius cap in multiples of the mean neighbourhood radius (RMS distance to the K
   * neighbours), in (0, 1000]. Default 5. */
  void setRadiusCapFactor(double factor) { params_.radius_cap_factor = factor; }
  double getRadiusCapFactor() const { return params_.radius_cap_factor; }
  /** \brief The optimised point stands for its ball when within this fraction of the radius of
   * the centre, else the centre (the paper: 1). */
  void setMaxRepresentativeOffset(double fraction) { params_.max_representative_offset = fraction; }
  double getMaxRepresentativeOffset() const { return params_.max_representative_offset; }
  /** \brief The optimised point moves from the centre only along the directions of the ball's
   * quadric whose eigenvalue is above this fraction of the largest (Parameters::representative_cutoff). */
  void setRepresentativeCutoff(double fraction) { params_.representative_cutoff = fraction; }
  double getRepresentativeCutoff() const { return params_.representative_cutoff; }
  /** \brief A ball whose points scatter about their tangent planes by more than this fraction of
   * its radius keeps its centre (Parameters::max_roughness). */
  void setMaxRoughness(double fraction) { params_.max_roughness = fraction; }
  double getMaxRoughness() const { return params_.max_roughness; }
  /** \brief Feature points thinned along the edges to one per this many mean neighbourhood radii;
   * 0 keeps them all (Parameters::feature_spacing; a target size sets it itself). */
  void setFeatureSpacing(double radii) { params_.feature_spacing = radii; }
  double getFeatureSpacing() const { return params_.feature_spacing; }
  /** \brief Move a smooth ball's representative onto the quadratic fitted to its points (default
   * on; off is the paper's method; Parameters::representative_fit). */
  void setRepresentativeFit(bool on) { params_.representative_fit = on; }
  bool getRepresentativeFit() const { return params_.representative_fit; }
  /** \brief Move the fitted representatives towards the centres of the points nearest to them,
   * along their fitted surfaces (default on; off is the paper's method;
   * Parameters::relax_representatives). */
  void setRelaxRepresentatives(bool on) { params_.relax_representatives = on; }
  bool getRelaxRepresentatives() const { return params_.relax_representatives; }
  /** \brief No input point farther than factor × the radius cap from the output; 0 = off (see
   * Parameters::max_gap_factor; target-size mode: setTargetGapFactor). */
  void setMaxGapFactor(double factor) { params_.max_gap_factor = factor; }
  double getMaxGapFactor() const { return params_.max_gap_factor; }
  void setTargetGapFactor(double factor) { params_.target_gap_factor = factor; }
  double getTargetGapFactor() const { return params_.target_gap_factor; }

  /** \brief Every input point within `distance` (input units) of the output's surface
   * (Parameters::max_deviation; 0 = off); the measured deviation is in getResult().summary. */
  void setMaxDeviation(double distance)
  {
    params_.max_deviation = distance;
    params_.max_deviation_of_L = 0.0;
  }
  /** \brief The same bound as a fraction of the bounding box's diagonal
   * (Parameters::max_deviation_of_L). */
  void setMaxDeviationOfDiagonal(double fraction)
  {
    params_.max_deviation_of_L = fraction;
    params_.max_deviation = 0.0;
  }
  double getMaxDeviation() const { return params_.max_deviation; }
  double getMaxDeviationOfDiagonal() const { return params_.max_deviation_of_L; }
  /** \brief Measure and report the deviation without a bound (Parameters::report_deviation). */
  void setReportDeviation(bool on) { params_.report_deviation = on; }
  bool getReportDeviation() const { return params_.report_deviation; }
  /** \brief With a target size: radius cap = factor × the spacing the target implies (0: use the
   * radius cap factor). */
  void setTargetRadiusCap(double factor) { params_.target_radius_cap = factor; }
  double getTargetRadiusCap() const { return params_.target_radius_cap; }

  /** \brief Seed of the centre order. Default 42 (fixed, never the clock). */
  void setSeed(std::uint64_t seed) { params_.seed = seed; }
  std::uint64_t getSeed() const { return params_.seed; }

  /** \brief Use the input's normal_x/y/z instead of estimating normals (point types with
   * normals only). Default false. The output's normals (point types with normals): a feature
   * keeps its own; a representative gets the weighted mean of its ball's normals, the input's
   * with this set, the estimated ones (eq. 2, turned towards the sensor origin) without it.
   * (pcd_simplify and ecs_node instead keep every input field of the representative's source
   * point, its normal included.) */
  void setUseInputNormals(bool use) { params_.use_input_normals = use; }
  bool getUseInputNormals() const { return params_.use_input_normals; }

  /** \brief Threads for the per-point stages, 0 = all. The output does not depend on it. */
  void setNumberOfThreads(int threads) { params_.threads = threads; }
  int getNumberOfThreads() const { return params_.threads; }

  /** \brief Ask for about `size` output points instead of a T_err (0 turns it off). T_err is
   * searched until the size is within 1%, or the closest size reachable. */
  void setTargetSize(std::size_t size) { params_.target_size = size; }
  std::size_t getTargetSize() const { return params_.target_size; }

  /** \brief Progress reports during filter() (stage name, fraction). */
  void setProgressCallback(ProgressCallback cb) { progress_ = std::move(cb); }

  /** \brief What the last filter() did: labels, balls, mapping, summary. */
  const Result& getResult() const { return result_; }

protected:
  using pcl::Filter<PointT>::input_;
  using pcl::Filter<PointT>::indices_;
  using pcl::Filter<PointT>::filter_name_;

  /** \brief Validate, run the method, assemble the output. Never throws. */
  void applyFilter(PointCloud& output) override;

private:
  /** \brief Our own validation: pcl's initCompute() is not virtual in PCL 1.13. */
  bool validateForRun(std::string& why) const;

  Parameters params_;
  Result result_;
  ProgressCallback progress_;
};

}  // namespace pcl_ecs

#if defined(PCL_NO_PRECOMPILE) || defined(PCL_ECS_NO_PRECOMPILE)
#include <pcl_ecs/impl/feature_aware_cover_simplify.hpp>
#endif
