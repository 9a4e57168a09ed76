/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The pose maths registration, slam, sim and evaluation share, inline and free of PCL
 * types: the cross-product matrix, SO(3) exp / log, the rotation angle, Euler ZYX both
 * ways (PCL's 6-vector) and the error between two poses.
 */
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cmath>

namespace pcl_parallel {

/** The cross-product matrix [v]x: [v]x u = v x u. */
inline Eigen::Matrix3d
skew(const Eigen::Vector3d& v)
{
  Eigen::Matrix3d s;
  s << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return s;
}

/** SO(3) exponential: the rotation by |w| about w / |w| (Rodrigues); identity at w = 0. */
inline Eigen::Matrix3d
so3Exp(const Eigen::Vector3d& w)
{
  const double angle = w.norm();
  if (!(angle > 0.0))
    return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

/** SO(3) logarithm: the rotation vector (angle times unit axis) of r. */
inline Eigen::Vector3d
so3Log(const Eigen::Matrix3d& r)
{
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}

/** Angle (rad, in [0, pi]) of the rotation r: atan2(|skew part|, (trace - 1) / 2), which,
 *  unlike acos((trace - 1) / 2), keeps small angles of float-rounded matrices. */
inline double
rotationAngle(const Eigen::Matrix3d& r)
{
  // 2 sin(theta) is the norm of the skew part, 2 cos(theta) + 1 the trace (Rodrigues).
  const Eigen::Vector3d w(r(2, 1) - r(1, 2), r(0, 2) - r(2, 0), r(1, 0) - r(0, 1));
  return std::atan2(0.5 * w.norm(), 0.5 * (r.trace() - 1.0));
}

/** R = Rz(yaw) Ry(pitch) Rx(roll), PCL's Euler convention (pcl::getTransformation). */
inline Eigen::Matrix3d
eulerZYXToRotation(double roll, double pitch, double yaw)
{
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

/** Inverse of eulerZYXToRotation(): (roll, pitch, yaw). At pitch = +-90 deg (gimbal lock)
 *  roll and yaw are not unique: roll is set to 0 and yaw carries the whole rotation, so
 *  the round trip still gives the same matrix. */
inline Eigen::Vector3d
rotationToEulerZYX(const Eigen::Matrix3d& r)
{
  // R(2,0) = -sin(pitch); atan2 instead of PCL's asin keeps pitch accurate near +-90 deg.
  const double cp = std::hypot(r(0, 0), r(1, 0));
  const double pitch = std::atan2(-r(2, 0), cp);
  if (cp > 1e-9)
    return {std::atan2(r(2, 1), r(2, 2)), pitch, std::atan2(r(1, 0), r(0, 0))};
  // Gimbal lock: only yaw -+ roll is defined; put it all into yaw.
  return {0.0, pitch, std::atan2(-r(0, 1), r(1, 1))};
}

/** PCL's 6-vector (x, y, z, roll, pitch, yaw), T = Tr * Rz(yaw) * Ry(pitch) * Rx(roll)
 *  as pcl::getTransformation, as a 4x4 in double. */
inline Eigen::Matrix4d
poseToMatrix(const Eigen::Matrix<float, 6, 1>& pose)
{
  const Eigen::Matrix<double, 6, 1> p = pose.cast<double>();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = eulerZYXToRotation(p(3), p(4), p(5));
  m.topRightCorner<3, 1>() = p.head<3>();
  return m;
}

/** Inverse of poseToMatrix() (see rotationToEulerZYX() at gimbal lock). */
inline Eigen::Matrix<float, 6, 1>
matrixToPose(const Eigen::Matrix4d& m)
{
  Eigen::Matrix<float, 6, 1> out;
  out.head<3>() = m.topRightCorner<3, 1>().cast<float>();
  out.tail<3>() = rotationToEulerZYX(m.topLeftCorner<3, 3>()).cast<float>();
  return out;
}

/** `pose` with its rotation orthonormal again (the nearest rotation, through a normalised
 *  quaternion): products of many poses drift from SO(3) by rounding. */
inline Eigen::Matrix4d
orthonormalized(const Eigen::Matrix4d& pose)
{
  Eigen::Matrix4d out = pose;
  out.topLeftCorner<3, 3>() = Eigen::Quaterniond(Eigen::Matrix3d(pose.topLeftCorner<3, 3>()))
                                  .normalized()
                                  .toRotationMatrix();
  return out;
}

/** The error of pose a against pose b: the angle (rad) of the rotation between them,
 *  R_a^T R_b, and the distance between their positions (in the poses' unit). */
struct PoseError {
  /** Rotation angle between the two poses (rad). */
  double angle = 0.0;
  /** Distance between the two positions (the poses' unit). */
  double distance = 0.0;
};

/** The error of pose \a a against pose \a b: angle of R_aᵀR_b and distance of the positions. */
inline PoseError
poseError(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b)
{
  PoseError e;
  e.angle = rotationAngle(a.topLeftCorner<3, 3>().transpose() * b.topLeftCorner<3, 3>());
  e.distance = (a.topRightCorner<3, 1>() - b.topRightCorner<3, 1>()).norm();
  return e;
}

} // namespace pcl_parallel
