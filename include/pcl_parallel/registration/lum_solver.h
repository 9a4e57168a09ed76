/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Non-template core of ParallelLUM: pose conversions, the 6D linearisation of one link
 * and the sparse solve of G X = B. Compiled once in src/registration/lum_solver.cpp.
 */
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace pcl_parallel {
class KdTreeIndex;
namespace lum {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

/** PCL's 6-vector (x, y, z, roll, pitch, yaw), T = Tr * Rz(yaw) * Ry(pitch) * Rx(roll)
 *  as pcl::getTransformation, as a 4x4 in double. */
Eigen::Matrix4d
poseToMatrix(const Eigen::Matrix<float, 6, 1>& pose);

/** Inverse of poseToMatrix(). At pitch = +-90 deg (gimbal lock) roll and yaw are not
 *  unique: roll is set to 0 and yaw carries the whole rotation, so the round trip still
 *  gives the same matrix. */
Eigen::Matrix<float, 6, 1>
matrixToPose(const Eigen::Matrix4d& m);

/** Left (world-frame) update of a pose by delta = (t, w). The linearisation below models
 *  it to first order as moving a world point p to p + w x p + t. Any rigid motion with
 *  that expansion is a valid update; this one rotates by the rotation vector w
 *  (Rodrigues, exact) about the pose's own position c and translates by t + w x c, so
 *  points near the scan, the ones its links constrain, move with an error of order
 *  |w|^2 |p - c| instead of |w|^2 |p| (which grows with the distance to the world
 *  origin, e.g. along a long trajectory). */
void
applyUpdate(Eigen::Matrix4d& pose, const Vector6d& delta);

/** Rotation angle (rad) and translation distance between two poses: evaluation::poseError
 *  (the one place pose errors are computed), kept for existing callers. */
void
poseError(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b, double& angle, double& dist);

/** `pose` with its rotation orthonormal again (the nearest rotation, through a normalised
 *  quaternion): products of many poses drift from SO(3) by rounding. */
Eigen::Matrix4d
orthonormalized(const Eigen::Matrix4d& pose);

/** The cross-product matrix [v]x: [v]x u = v x u. */
inline Eigen::Matrix3d
skew(const Eigen::Vector3d& v)
{
  Eigen::Matrix3d s;
  s << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return s;
}

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

/** The delta with applyUpdate(before, delta) == after (up to rounding): the inverse of
 *  applyUpdate, e.g. to express a link's pairwise alignment as a measurement. */
Vector6d
updateBetween(const Eigen::Matrix4d& before, const Eigen::Matrix4d& after);

/** Unit surface normals of a tree's points, indexed by tree position (KdTreeIndex::
 *  point()): the direction of least variance of each point's k nearest neighbours
 *  (itself included), in the tree's frame. Zero where the neighbourhood does not define
 *  a plane (fewer than 3 distinct points, or collinear ones). Parallel over points. */
std::vector<Eigen::Vector3f>
estimateNormals(const KdTreeIndex& tree, std::size_t k, unsigned num_threads);

/** One link's contribution to G X = B: cost (D + H^-1 g)^T H (D + H^-1 g) with
 *  D = delta_source - delta_target. */
struct LinkBlock {
  std::uint32_t source = 0;
  std::uint32_t target = 0;
  bool valid = false;
  Matrix6d info = Matrix6d::Zero();
  Vector6d grad = Vector6d::Zero();
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};

/** A measured relative pose between two vertices, besides the scan links (e.g. the front
 *  end's odometry): target^-1 source = measured, with `information` the inverse
 *  covariance of the error (translation, rotation vector) of a body-frame perturbation
 *  source Exp(e) (g2o's EdgeSE3 convention). */
struct PoseConstraint {
  std::uint32_t source = 0;
  std::uint32_t target = 0;
  Eigen::Matrix4d measured = Eigen::Matrix4d::Identity();
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

/**
 * \brief Assembles and solves the sparse normal equations G X = B over vertices
 * 1..n-1 (vertex 0 is the fixed reference) with Eigen's SimplicialLDLT in double
 * (paper Sec. III steps 3-4; the O(n^3) dense solve of PCL's LUM becomes a sparse
 * Cholesky whose cost follows the fill of the graph).
 *
 * Triplets are generated from the link blocks in link order, so G and B, and hence the
 * solution, do not depend on which thread computed which link. The symbolic analysis is
 * reused while the link structure stays the same.
 */
class PoseGraphSolver {
public:
  PoseGraphSolver();
  ~PoseGraphSolver();
  PoseGraphSolver(const PoseGraphSolver&) = delete;
  PoseGraphSolver&
  operator=(const PoseGraphSolver&) = delete;

  /** Solves for the updates of all n vertices (delta[0] = 0). Returns false if the
   *  factorisation fails (e.g. a vertex without a valid link). */
  bool
  solve(std::size_t num_vertices,
        const std::vector<LinkBlock, Eigen::aligned_allocator<LinkBlock>>& links,
        std::vector<Vector6d, Eigen::aligned_allocator<Vector6d>>& delta);

  /** Marginal covariance of vertex v (1..n-1) from the last factorisation: the 6x6
   *  diagonal block of G^-1 (paper step 5, "update the covariances"). Zero for v = 0. */
  Matrix6d
  covariance(std::size_t v) const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/** Vertices not connected to vertex 0 through the given (source, target) links. */
std::vector<std::uint32_t>
unreachableFromZero(std::size_t num_vertices,
                    const std::vector<std::pair<std::uint32_t, std::uint32_t>>& links);

} // namespace lum
} // namespace pcl_parallel
