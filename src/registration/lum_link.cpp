/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/registration/lum_link.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <algorithm>
#include <cmath>

namespace pcl_parallel {
namespace lum {

void
applyUpdate(Eigen::Matrix4d& pose, const Vector6d& delta)
{
  const Eigen::Vector3d t = delta.head<3>();
  const Eigen::Vector3d w = delta.tail<3>();
  const Eigen::Vector3d c = pose.topRightCorner<3, 1>();
  const Eigen::Matrix3d r = so3Exp(w);
  // p -> r (p - c) + c + t + w x c, i.e. p + w x p + t to first order.
  Eigen::Matrix4d d = Eigen::Matrix4d::Identity();
  d.topLeftCorner<3, 3>() = r;
  d.topRightCorner<3, 1>() = c - r * c + t + w.cross(c);
  pose = orthonormalized(d * pose); // over many updates
}

bool
LinkAccumulator::solveCentred(
    std::size_t min_pairs, Matrix6d& a, Vector6d& c, Vector6d& d_bar, const char** reason) const
{
  auto fail = [&](const char* why) {
    if (reason)
      *reason = why;
    return false;
  };
  if (n_ < std::max<std::size_t>(min_pairs, 3))
    return fail("too few point pairs");

  // A' and c' in the frame centred at origin_ (M' = [I, -[m']x]).
  a = sum_w_;
  a.bottomLeftCorner<3, 3>() = sum_w_.topRightCorner<3, 3>().transpose();
  a.topLeftCorner<3, 3>().diagonal().array() += static_cast<double>(n_identity_);
  a.topRightCorner<3, 3>() -= skew(sum_m_);
  a.bottomLeftCorner<3, 3>() += skew(sum_m_);
  a.bottomRightCorner<3, 3>() += sum_mmt_.trace() * Eigen::Matrix3d::Identity() - sum_mmt_;
  c = sum_wc_;
  c.head<3>() += sum_r_;
  c.tail<3>() += sum_mxr_;

  // Singular A: the pairs do not fix all six DoF (e.g. collinear points). Judged on the
  // unit-diagonal scaling, so units and point spread do not matter.
  const Vector6d scale = a.diagonal().cwiseSqrt().cwiseInverse();
  if (!scale.allFinite())
    return fail("degenerate point pairs");
  const Matrix6d a_scaled = scale.asDiagonal() * a * scale.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(a_scaled, Eigen::EigenvaluesOnly);
  if (eig.info() != Eigen::Success || !(eig.eigenvalues()(0) > 1e-9))
    return fail("singular covariance (the pairs do not constrain all six DoF)");
  d_bar = -Eigen::LDLT<Matrix6d>(a).solve(c);
  if (!d_bar.allFinite())
    return fail("non-finite measurement");
  return true;
}

bool
LinkAccumulator::measurement(std::size_t min_pairs, Vector6d& d_bar, const char** reason) const
{
  Matrix6d a;
  Vector6d c;
  if (!solveCentred(min_pairs, a, c, d_bar, reason))
    return false;
  // Centred D' = T D (see finish()), so D = (t' + o x w', w').
  d_bar.head<3>() += origin_.cross(Vector6d(d_bar).tail<3>());
  return true;
}

bool
LinkAccumulator::finish(std::size_t min_pairs,
                        double min_variance,
                        Matrix6d& info,
                        Vector6d& grad,
                        double* variance,
                        const char** reason) const
{
  info.setZero();
  grad.setZero();
  Matrix6d a;
  Vector6d c, d_bar;
  if (!solveCentred(min_pairs, a, c, d_bar, reason))
    return false;

  // Residual after the fit: sum r^T W r at D = -A^-1 c is sum r^T W r - c^T A^-1 c; its
  // expectation for isotropic noise s^2 is s^2 (sum tr W - 6).
  const double ssr = std::max(0.0, sum_rr_ + c.dot(d_bar));
  const double dof = 3.0 * static_cast<double>(n_identity_) + trace_w_ - 6.0;
  const double s2 = std::max(ssr / std::max(dof, 1.0), min_variance);

  // Back to world coordinates: M = M' T with T = [[I, -[o]x], [0, I]].
  Matrix6d t = Matrix6d::Identity();
  t.topRightCorner<3, 3>() = -skew(origin_);
  info = t.transpose() * a * t / s2;
  grad = t.transpose() * c / s2;
  if (variance)
    *variance = s2;
  if (!std::isfinite(s2) || !info.allFinite() || !grad.allFinite()) {
    info.setZero();
    grad.setZero();
    if (reason)
      *reason = "non-finite measurement";
    return false;
  }
  return true;
}

Vector6d
updateBetween(const Eigen::Matrix4d& before, const Eigen::Matrix4d& after)
{
  // after = D before with D = [r, c - r c + t + w x c] (applyUpdate), c = before's position.
  const Eigen::Matrix4d d = after * before.inverse();
  const Eigen::Matrix3d r = d.topLeftCorner<3, 3>();
  const Eigen::Vector3d w = so3Log(r);
  const Eigen::Vector3d c = before.topRightCorner<3, 1>();
  Vector6d delta;
  delta.head<3>() = d.topRightCorner<3, 1>() - c + r * c - w.cross(c);
  delta.tail<3>() = w;
  return delta;
}

namespace {

/** (t, rotation vector) of measured^-1 target^-1 source. */
Vector6d
constraintError(const PoseConstraint& c,
                const Eigen::Matrix4d& source_pose,
                const Eigen::Matrix4d& target_pose)
{
  const Eigen::Matrix4d e = c.measured.inverse() * target_pose.inverse() * source_pose;
  Vector6d e0;
  e0.head<3>() = e.topRightCorner<3, 1>();
  e0.tail<3>() = so3Log(e.topLeftCorner<3, 3>());
  return e0;
}

} // namespace

double
constraintChi2(const PoseConstraint& c,
               const Eigen::Matrix4d& source_pose,
               const Eigen::Matrix4d& target_pose)
{
  const Vector6d e0 = constraintError(c, source_pose, target_pose);
  return e0.dot(c.information * e0);
}

LinkBlock
constraintBlock(const PoseConstraint& c,
                const Eigen::Matrix4d& source_pose,
                const Eigen::Matrix4d& target_pose,
                const LinkBlock* link)
{
  LinkBlock b;
  b.source = c.source;
  b.target = c.target;
  const Vector6d e0 = constraintError(c, source_pose, target_pose);
  // Body perturbation of the source by the world update D = (t, w) (applyUpdate's model
  // p -> p + w x p + t): rotation R^T w, translation R^T (t + w x c), c its position.
  const Eigen::Matrix3d rt = source_pose.topLeftCorner<3, 3>().transpose();
  Matrix6d j = Matrix6d::Zero();
  j.topLeftCorner<3, 3>() = rt;
  j.topRightCorner<3, 3>() = -rt * skew(source_pose.topRightCorner<3, 1>());
  j.bottomRightCorner<3, 3>() = rt;
  // Cauchy IRLS weight (Black and Rangarajan 1996) from the current error, judged by the
  // scans' link where there is one: the update the constraint asks for in its information.
  double weight = 1.0;
  if (c.cauchy_scale > 0.0) {
    double chi2 = e0.dot(c.information * e0);
    if (link && link->valid) {
      const Vector6d d = j.partialPivLu().solve(e0); // J is invertible (block triangular)
      chi2 = d.dot(link->info * d);
    }
    weight = 1.0 / (1.0 + chi2 / c.cauchy_scale);
  }
  b.info = weight * (j.transpose() * c.information * j);
  b.grad = weight * (j.transpose() * (c.information * e0));
  b.valid = b.info.allFinite() && b.grad.allFinite();
  return b;
}

} // namespace lum
} // namespace pcl_parallel
