/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * One link of ParallelLUM's pose graph: the world-frame pose update it is linearised in,
 * the sufficient statistics of its point pairs, its block of G X = B, and the measured
 * pose constraints that enter the graph as link blocks, with their chi2. Non-template,
 * compiled once in src/registration/lum_link.cpp.
 */
#pragma once

#include <pcl_parallel/pose_math.h>

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>

namespace pcl_parallel {
namespace lum {

/** A 6-vector (t, w) of a pose update. */
using Vector6d = Eigen::Matrix<double, 6, 1>;
/** A 6x6 matrix (information, covariance). */
using Matrix6d = Eigen::Matrix<double, 6, 6>;

/** Left (world-frame) update of a pose by delta = (t, w). The linearisation below models
 *  it to first order as moving a world point p to p + w x p + t. Any rigid motion with
 *  that expansion is a valid update; this one rotates by the rotation vector w
 *  (Rodrigues, exact) about the pose's own position c and translates by t + w x c, so
 *  points near the scan, the ones its links constrain, move with an error of order
 *  |w|^2 |p - c| instead of |w|^2 |p| (which grows with the distance to the world
 *  origin, e.g. along a long trajectory). */
void
applyUpdate(Eigen::Matrix4d& pose, const Vector6d& delta);

/** The delta with applyUpdate(before, delta) == after (up to rounding): the inverse of
 *  applyUpdate, e.g. to express a link's pairwise alignment as a measurement. */
Vector6d
updateBetween(const Eigen::Matrix4d& before, const Eigen::Matrix4d& after);

/**
 * \brief Sufficient statistics of one link's point pairs (paper Sec. III step 2).
 *
 * For a pair with world points a (source scan i) and b (target scan j), residual
 * r = a - b and midpoint m = (a + b) / 2, perturbing both poses by delta = (t, w) as in
 * applyUpdate() changes r to first order into r + M (delta_i - delta_j) with
 * M = [I, -[m]x] (the second-order terms w x (a - m) are dropped, as Lu/Milios and
 * Borrmann et al. 2008, Sec. 3, do with the pair averages). The link's least-squares
 * problem is thus linear in the pose difference D = delta_i - delta_j:
 *   min_D sum (r + M D)^T W (r + M D),  A = sum M^T W M,  c = sum M^T W r,
 * D-bar = -A^-1 c is the measurement and C = s^2 A^-1 its covariance, s^2 the residual
 * variance after the fit (Borrmann et al. 2008, Eq. 9-11). add() is the paper's
 * point-to-point pair (W = I), summed as moments; addWeighted() takes any 3x3 weight,
 * e.g. point-to-plane n n^T + lambda I (Chen/Medioni 1992). Both kinds may be mixed.
 *
 * Midpoints are accumulated relative to the first one (origin_) and shifted back in
 * finish(), so large world coordinates do not cancel away the precision of the sums.
 * add() and addWeighted() are inline: they run once per point pair on the hot path.
 */
class LinkAccumulator {
public:
  /** Adds a pair of world points: \a a on the source scan, \a b on the target scan. */
  void
  add(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
  {
    const Eigen::Vector3d r = a - b;
    const Eigen::Vector3d m = midpoint(a, b);
    ++n_identity_;
    sum_m_ += m;
    sum_mmt_ += m * m.transpose();
    sum_r_ += r;
    sum_mxr_ += m.cross(r);
    sum_rr_ += r.squaredNorm();
  }

  /** A pair whose residual is weighted by the symmetric positive semi-definite w. */
  void
  addWeighted(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Matrix3d& w)
  {
    const Eigen::Vector3d r = a - b;
    const Eigen::Vector3d m = midpoint(a, b);
    const Eigen::Matrix3d mx = skew(m);
    const Eigen::Matrix3d w_mx = w * mx;
    // M^T W M = [[W, -W [m]x], [[m]x W, -[m]x W [m]x]]; the lower-left block is the
    // transpose of the upper-right one and is filled in finish().
    sum_w_.topLeftCorner<3, 3>() += w;
    sum_w_.topRightCorner<3, 3>() -= w_mx;
    sum_w_.bottomRightCorner<3, 3>() -= mx * w_mx;
    const Eigen::Vector3d wr = w * r;
    sum_wc_.head<3>() += wr;
    sum_wc_.tail<3>() += m.cross(wr);
    sum_rr_ += r.dot(wr);
    trace_w_ += w.trace();
  }

  /** Number of pairs added. */
  std::size_t
  size() const
  {
    return n_;
  }

  /** The link's measurement D-bar = -A^-1 c alone (e.g. for a step of pairwise ICP).
   *  False on the same conditions as finish(). */
  bool
  measurement(std::size_t min_pairs, Vector6d& d_bar, const char** reason = nullptr) const;

  /** Fills the link's normal-equation blocks in world coordinates: information matrix
   *  H = A / s^2 (= C^-1) and g = c / s^2 (= -C^-1 D-bar). Returns false (with a reason)
   *  for fewer than min_pairs pairs or a singular A, or a non-finite result. s^2 is kept
   *  at or above min_variance, so a link of exact pairs gets a large finite weight. */
  bool
  finish(std::size_t min_pairs,
         double min_variance,
         Matrix6d& info,
         Vector6d& grad,
         double* variance = nullptr,
         const char** reason = nullptr) const;

private:
  Eigen::Vector3d
  midpoint(const Eigen::Vector3d& a, const Eigen::Vector3d& b)
  {
    if (n_++ == 0)
      origin_ = 0.5 * (a + b);
    return 0.5 * (a + b) - origin_;
  }
  /** A and c in the frame centred at origin_, and the measurement; false with a reason. */
  bool
  solveCentred(std::size_t min_pairs,
               Matrix6d& a,
               Vector6d& c,
               Vector6d& d_bar,
               const char** reason) const;

  std::size_t n_ = 0;
  std::size_t n_identity_ = 0;
  Eigen::Vector3d origin_ = Eigen::Vector3d::Zero();
  // add(): moments of the midpoints and residuals.
  Eigen::Vector3d sum_m_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d sum_mmt_ = Eigen::Matrix3d::Zero();
  Eigen::Vector3d sum_r_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d sum_mxr_ = Eigen::Vector3d::Zero();
  // addWeighted(): A and c directly (upper blocks of A), and the trace of the weights.
  Matrix6d sum_w_ = Matrix6d::Zero();
  Vector6d sum_wc_ = Vector6d::Zero();
  double trace_w_ = 0.0;
  double sum_rr_ = 0.0; ///< sum r^T W r over both kinds
};

/** One link's contribution to G X = B: cost (D + H^-1 g)^T H (D + H^-1 g) with
 *  D = delta_source - delta_target. */
struct LinkBlock {
  /** The link's source vertex. */
  std::uint32_t source = 0;
  /** The link's target vertex. */
  std::uint32_t target = 0;
  /** False when the link is dropped for this iteration (too few pairs, open directions). */
  bool valid = false;
  /** The link's information matrix H = C⁻¹. */
  Matrix6d info = Matrix6d::Zero();
  /** The link's gradient g. */
  Vector6d grad = Vector6d::Zero();
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};

/** A measured relative pose between two vertices, besides the scan links (e.g. the front
 *  end's odometry): target^-1 source = measured, with `information` the inverse
 *  covariance of the error (translation, rotation vector) of a body-frame perturbation
 *  source Exp(e) (g2o's EdgeSE3 convention). */
struct PoseConstraint {
  /** The constraint's source vertex. */
  std::uint32_t source = 0;
  /** The constraint's target vertex. */
  std::uint32_t target = 0;
  /** The measured relative pose Z. */
  Eigen::Matrix4d measured = Eigen::Matrix4d::Identity();
  /** Its information matrix (body-frame perturbation of the source). */
  Matrix6d information = Matrix6d::Zero();
  /** > 0: a Cauchy kernel, the information scaled by 1 / (1 + chi2 / cauchy_scale) at
   *  each linearisation (IRLS), so that a constraint the scans contradict yields; chi2 is
   *  the error in the information of the scan link between the same two vertices where
   *  one is measured (constraintBlock), else its own e^T I e. 0: plain least squares. */
  double cauchy_scale = 0.0;
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};

/** The constraint's contribution to G X = B at the current poses, as a link block: its
 *  error e0 = (t, w) of measured^-1 target^-1 source and the body Jacobian J of the
 *  world-frame updates (applyUpdate), H = J^T I J and g = J^T I e0 (times the Cauchy
 *  weight). `link`: this iteration's valid block of the scan link from source to target,
 *  if any; the Cauchy kernel then weighs the update the constraint asks for, d = J^-1 e0,
 *  in the link's information, chi2 = d^T H_link d: the scans contradict a constraint only
 *  in directions their pairs constrain, and a direction they leave open (a wall seen
 *  alone) is not a contradiction (docs/design.md, "Sequence constraints"). */
LinkBlock
constraintBlock(const PoseConstraint& c,
                const Eigen::Matrix4d& source_pose,
                const Eigen::Matrix4d& target_pose,
                const LinkBlock* link = nullptr);

/** The constraint's squared Mahalanobis error e0^T I e0 at the given poses. */
double
constraintChi2(const PoseConstraint& c,
               const Eigen::Matrix4d& source_pose,
               const Eigen::Matrix4d& target_pose);
} // namespace lum
} // namespace pcl_parallel
