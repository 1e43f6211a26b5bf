// quadric.h — paper eq. 13: Q(x) = sum_j w_j (n_j · (x - p_j))², a 3×3 quadratic form
// Q(x) = xᵀAx - 2bᵀx + c, kept relative to the ball centre (x and p_j are offsets from c), and
// its stable minimiser: A is rank-deficient on flat patches, so the minimiser uses a truncated
// pseudo-inverse — directions with eigenvalue below `relative_cutoff` · λ_max are left at 0,
// i.e. at the centre. On a plane x_min is therefore the point of the plane nearest c; on a sharp
// edge (two normal directions) it is the point of the edge nearest c.
#pragma once

#include <Eigen/Core>

namespace pcl_ecs
{

/** \brief An accumulated quadric error form relative to a centre. */
struct Quadric
{
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  double c = 0.0;
  double weight_sum = 0.0;  ///< sum of the w_j (the denominator of the normalized error)

  /** \brief Add the plane through `offset` (p_j - centre) with unit normal `n`, weighted by w. */
  void add(double w, const Eigen::Vector3d& n, const Eigen::Vector3d& offset)
  {
    addPlane(w, n, n.dot(offset));
  }

  /** \brief Add the plane n·x = d (unit n, d = n·(p_j - centre)), weighted by w. */
  void addPlane(double w, const Eigen::Vector3d& n, double d)
  {
    A.noalias() += w * n * n.transpose();
    b += (w * d) * n;
    c += w * d * d;
    weight_sum += w;
  }

  /** \brief Q at x (an offset from the centre). */
  double evaluate(const Eigen::Vector3d& x) const { return x.dot(A * x) - 2.0 * b.dot(x) + c; }
};

/** \brief The minimiser of a quadric and its value. */
struct QuadricMinimum
{
  Eigen::Vector3d x = Eigen::Vector3d::Zero();  ///< offset from the centre
  double value = 0.0;                           ///< Q(x) >= 0
  int rank = 0;                                 ///< directions kept by the pseudo-inverse
};

/** \brief Default relative eigenvalue cutoff of the truncated pseudo-inverse. */
constexpr double kQuadricCutoff = 1e-3;

/** \brief The minimiser of q closest to the centre, through a truncated pseudo-inverse.
 * Never divides by a near-zero eigenvalue; an empty quadric gives x = 0, value 0. */
QuadricMinimum minimizeQuadric(const Quadric& q, double relative_cutoff = kQuadricCutoff);

}  // namespace pcl_ecs
