#include <pcl_ecs/stages/surface_deviation.h>

#include <pcl_ecs/stages/gap_fill.h>

#include "../detail/point_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include <Eigen/Eigenvalues>
#include <nanoflann.hpp>

namespace pcl_ecs
{

namespace
{
/// nanoflann's view of the output points.
struct Points
{
  const std::vector<Eigen::Vector3d>* p;
  std::size_t kdtree_get_point_count() const { return p->size(); }
  double kdtree_get_pt(std::size_t i, std::size_t d) const { return (*p)[i](static_cast<Eigen::Index>(d)); }
  template <class BBox>
  bool kdtree_get_bbox(BBox&) const
  {
    return false;
  }
};
using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Points>, Points, 3,
                                                 std::uint32_t>;
}  // namespace

struct OutputSurface::Impl
{
  std::vector<Eigen::Vector3d> points;
  Points view{nullptr};
  std::unique_ptr<Tree> tree;
  int k = 8;
};

OutputSurface::OutputSurface(const std::vector<Eigen::Vector3d>& outputs, int k) : impl_(std::make_unique<Impl>())
{
  impl_->points = outputs;
  impl_->view.p = &impl_->points;
  impl_->k = std::max(1, k);
  if (!impl_->points.empty())
  {
    impl_->tree = std::make_unique<Tree>(3, impl_->view, nanoflann::KDTreeSingleIndexAdaptorParams(16));
    impl_->tree->buildIndex();
  }
}

OutputSurface::~OutputSurface() = default;

PointDeviation OutputSurface::at(const Eigen::Vector3d& q) const
{
  PointDeviation d;
  if (!impl_->tree)
    return d;
  constexpr int kMax = 32;
  const int want = std::min<int>(std::min(impl_->k, kMax), static_cast<int>(impl_->points.size()));
  std::uint32_t idx[kMax];
  double d2[kMax];
  const double query[3] = {q.x(), q.y(), q.z()};
  const auto found = static_cast<int>(impl_->tree->knnSearch(query, static_cast<std::size_t>(want), idx, d2));
  d.nearest = std::sqrt(d2[0]);
  d.plane = d.nearest;
  if (found < 3)
    return d;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (int j = 0; j < found; ++j)
    c += impl_->points[idx[j]];
  c /= static_cast<double>(found);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int j = 0; j < found; ++j)
  {
    const Eigen::Vector3d v = impl_->points[idx[j]] - c;
    cov.noalias() += v * v.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
  es.computeDirect(cov);
  d.plane = std::abs((q - c).dot(es.eigenvectors().col(0)));
  return d;
}

DeviationSummary summarizeDeviations(std::vector<double> deviations)
{
  DeviationSummary s;
  if (deviations.empty())
    return s;
  double sq = 0.0;
  for (const double d : deviations)
  {
    s.max = std::max(s.max, d);
    sq += d * d;
  }
  s.rms = std::sqrt(sq / static_cast<double>(deviations.size()));
  // The 99th percentile: the value at rank ceil(0.99 n) - 1 of the sorted values.
  const auto rank = static_cast<std::size_t>(std::ceil(0.99 * static_cast<double>(deviations.size()))) - 1;
  std::nth_element(deviations.begin(), deviations.begin() + static_cast<std::ptrdiff_t>(rank), deviations.end());
  s.p99 = deviations[rank];
  return s;
}

namespace
{
std::vector<PointDeviation> measure(const CoverInput& in, const CoverOutput& out, int threads)
{
  const OutputSurface surface(outputPositions(in, out));
  std::vector<PointDeviation> d(in.cloud.size());
  const auto count = static_cast<std::ptrdiff_t>(in.cloud.size());
#pragma omp parallel for schedule(dynamic, 2048) num_threads(threads)
  for (std::ptrdiff_t i = 0; i < count; ++i)
    d[static_cast<std::size_t>(i)] = surface.at(in.cloud[static_cast<std::size_t>(i)].getVector3fMap().cast<double>());
  return d;
}

/// PointDeviation::distance of each.
std::vector<double> distances(const std::vector<PointDeviation>& d)
{
  std::vector<double> distance(d.size());
  for (std::size_t i = 0; i < d.size(); ++i)
    distance[i] = d[i].distance();
  return distance;
}
}  // namespace

std::vector<double> coverDeviations(const CoverInput& in, const CoverOutput& out, int threads)
{
  return distances(measure(in, out, threads));
}

std::size_t boundDeviation(const CoverInput& in, const Parameters& params, double error_threshold, double bound,
                           CoverOutput& out, std::vector<double>& deviations)
{
  const int threads = resolveThreads(params.threads);
  std::size_t added = 0;
  for (int round = 0;; ++round)
  {
    const std::vector<PointDeviation> d = measure(in, out, threads);
    std::vector<std::size_t> over;
    double side = 0.0;
    for (std::size_t i = 0; i < d.size(); ++i)
      if (bound > 0.0 && d[i].distance() > bound && out.owner[i] >= 0)
      {
        over.push_back(i);
        side = std::max(side, 0.5 * d[i].nearest);
      }
    if (over.empty())
    {
      deviations = distances(d);
      return added;
    }
    // After a few rounds every point over the bound is added at once (each round adds at least
    // the first one, so the rounds end either way).
    const bool skip_near = round < 4 && side > 0.0;
    PointGrid grid(side > 0.0 ? side : 1.0);
    for (const std::size_t i : over)
    {
      const Eigen::Vector3d q = in.cloud[i].getVector3fMap().cast<double>();
      if (skip_near && grid.near(q, 0.5 * d[i].nearest))
        continue;
      addPointBall(in, params, error_threshold, i, out);
      grid.insert(q);
      ++added;
    }
  }
}

}  // namespace pcl_ecs
