// cocone_reconstruction.h — pcl_ecs::Cocone<PointT>: the Cocone surface as a PCL surface class.
// Drop it in where pcl::GreedyProjectionTriangulation stood: setInputCloud, setIndices,
// reconstruct(pcl::PolygonMesh&). No normals and no search tree are needed. As with every PCL
// MeshConstruction, the mesh's cloud is the whole input cloud and the polygons index it; points
// outside the indices, non-finite points and duplicates are simply not referenced.
#pragma once

#include <pcl_ecs/surface/cocone.h>

#include <pcl/PolygonMesh.h>
#include <pcl/point_cloud.h>
#include <pcl/Vertices.h>
#include <pcl/console/print.h>
#include <pcl/surface/reconstruction.h>

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace pcl_ecs
{

/** \brief The scan a cloud was simplified from as surface::coconeReconstruct and
 * Cocone::setScanSupport take it: its points' x, y, z and, per scan point, the sample standing for
 * it (Result::input_to_output of the simplification; empty: each scan point's nearest sample). */
template <typename PointT>
surface::ScanSupport scanSupport(const pcl::PointCloud<PointT>& scan, std::vector<std::int64_t> sample_of = {})
{
  surface::ScanSupport s;
  s.points.reserve(scan.size());
  for (const PointT& p : scan)
    s.points.emplace_back(p.x, p.y, p.z);
  s.sample_of = std::move(sample_of);
  return s;
}

template <typename PointInT>
class Cocone : public pcl::MeshConstruction<PointInT>
{
public:
  using Ptr = std::shared_ptr<Cocone<PointInT>>;
  using ConstPtr = std::shared_ptr<const Cocone<PointInT>>;
  using pcl::MeshConstruction<PointInT>::reconstruct;

  Cocone() { this->check_tree_ = false; }

  /** \brief All parameters at once (see surface::CoconeParameters for their meaning). */
  void setParameters(const surface::CoconeParameters& p) { params_ = p; }
  const surface::CoconeParameters& getParameters() const { return params_; }

  /** \brief θ (radians): the cocone is the complement of the double cone of half-angle π/2 − θ. */
  void setCoconeAngle(double radians) { params_.cocone_angle = radians; }
  double getCoconeAngle() const { return params_.cocone_angle; }
  /** \brief Keep open surfaces open (Dey-Giesen boundary detection). */
  void setDetectBoundaries(bool on) { params_.detect_boundaries = on; }
  bool getDetectBoundaries() const { return params_.detect_boundaries; }
  void setBoundaryRatio(double rho) { params_.boundary_ratio = rho; }
  double getBoundaryRatio() const { return params_.boundary_ratio; }
  void setBoundaryNormalAngle(double radians) { params_.boundary_normal_angle = radians; }
  double getBoundaryNormalAngle() const { return params_.boundary_normal_angle; }
  void setSharpEdgeAngle(double radians) { params_.sharp_edge_angle = radians; }
  double getSharpEdgeAngle() const { return params_.sharp_edge_angle; }
  void setMaxEdgeRatio(double ratio) { params_.max_edge_ratio = ratio; }
  double getMaxEdgeRatio() const { return params_.max_edge_ratio; }
  /** \brief Seal every remaining boundary loop (a closed surface for closed objects). */
  void setWatertight(bool on) { params_.watertight = on; }
  bool getWatertight() const { return params_.watertight; }
  void setFillHoleEdges(std::size_t edges) { params_.fill_hole_edges = edges; }
  std::size_t getFillHoleEdges() const { return params_.fill_hole_edges; }

  /** \brief Per point of the input cloud, the radius of the ball it stands for (pointRadii of a
   * FeatureAwareCoverSimplify result, whose output cloud is this input; 0 for a point kept as it is,
   * judged by its nearest neighbour's ball; not finite where unknown): triangles joining two balls
   * far from overlapping are refused (surface::kApartBallRatio). Empty (the
   * default): no radius known. A size other than the input cloud's fails reconstruct(). */
  void setSampleRadii(std::vector<double> radius) { radius_ = std::move(radius); }
  const std::vector<double>& getSampleRadii() const { return radius_; }
  /** \brief The scan the input cloud was simplified from, for CoconeParameters::open_tunnels: its
   * points and, per scan point, the input cloud's point standing for it (Result::input_to_output;
   * empty: the nearest; an entry outside the cloud or not among the indices used: none). Empty (the
   * default): no scan. */
  void setScanSupport(surface::ScanSupport scan) { scan_ = std::move(scan); }
  const surface::ScanSupport& getScanSupport() const { return scan_; }
  /** \brief What the last reconstruct() did; the error is empty on success. */
  const surface::CoconeStats& getStats() const { return stats_; }
  const std::string& getLastError() const { return error_; }

protected:
  std::string getClassName() const override { return "Cocone"; }

  void performReconstruction(pcl::PolygonMesh& output) override { performReconstruction(output.polygons); }

  void performReconstruction(std::vector<pcl::Vertices>& polygons) override
  {
    polygons.clear();
    const auto& indices = *this->indices_;
    const auto& cloud = *this->input_;
    std::vector<Eigen::Vector3d> pts;
    pts.reserve(indices.size());
    for (const auto idx : indices)
    {
      const PointInT& p = cloud[static_cast<std::size_t>(idx)];
      pts.emplace_back(p.x, p.y, p.z);
    }
    std::vector<double> radius;
    if (!radius_.empty())
    {
      if (radius_.size() != cloud.size())
      {
        error_ = "sample radii for " + std::to_string(radius_.size()) + " points, but the input cloud has " +
                 std::to_string(cloud.size());
        stats_ = surface::CoconeStats{};
        PCL_ERROR("[pcl_ecs::%s::reconstruct] %s\n", getClassName().c_str(), error_.c_str());
        return;
      }
      radius.reserve(indices.size());
      for (const auto idx : indices)
        radius.push_back(radius_[static_cast<std::size_t>(idx)]);
    }
    // The scan's samples by their position among the indices used (the scan copied only when
    // those are not the cloud itself, in order).
    bool whole_cloud = indices.size() == cloud.size();
    for (std::size_t k = 0; k < indices.size() && whole_cloud; ++k)
      whole_cloud = static_cast<std::size_t>(indices[k]) == k;
    surface::ScanSupport scan;
    if (!scan_.sample_of.empty() && !whole_cloud)
    {
      std::vector<std::int64_t> position(cloud.size(), -1);
      for (std::size_t k = 0; k < indices.size(); ++k)
        position[static_cast<std::size_t>(indices[k])] = static_cast<std::int64_t>(k);
      scan.points = scan_.points;
      scan.sample_of.reserve(scan_.sample_of.size());
      for (const std::int64_t o : scan_.sample_of)
        scan.sample_of.push_back(o >= 0 && static_cast<std::size_t>(o) < cloud.size() ? position[static_cast<std::size_t>(o)] : -1);
    }
    const surface::CoconeResult r =
        surface::coconeReconstruct(pts, params_, radius, scan_.sample_of.empty() || whole_cloud ? scan_ : scan);
    stats_ = r.stats;
    error_ = r.error;
    if (!r.ok())
    {
      PCL_ERROR("[pcl_ecs::%s::reconstruct] %s\n", getClassName().c_str(), r.error.c_str());
      return;
    }
    polygons.resize(r.triangles.size());
    for (std::size_t t = 0; t < r.triangles.size(); ++t)
    {
      polygons[t].vertices.resize(3);
      for (int k = 0; k < 3; ++k)
        polygons[t].vertices[k] = static_cast<pcl::index_t>(indices[r.triangles[t][k]]);
    }
  }

private:
  surface::CoconeParameters params_;
  std::vector<double> radius_;
  surface::ScanSupport scan_;
  surface::CoconeStats stats_;
  std::string error_;
};

}  // namespace pcl_ecs
