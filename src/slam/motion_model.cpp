/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/slam/motion_model.h>
#include <pcl_parallel/slam/preprocess.h>

#include <algorithm>

namespace pcl_parallel {
namespace slam {

namespace {
/** Constant velocity in time scales the last step by gap / span, within [1/k, k]: a gap
 *  far longer than the last may hide a stop (keyframes taken by distance), and a tenfold
 *  extrapolation puts the prediction out of pICP's reach (docs/design.md, "Keyframes"). */
constexpr double kMaxVelocityScale = 4.0;
} // namespace

MotionModel::MotionModel(double sweep_period, double min_step)
    : sweep_period_(sweep_period)
    , min_step_(min_step)
{}

MotionPrediction
MotionModel::predict(const std::optional<Pose>& odometry, std::optional<double> stamp)
{
  MotionPrediction m;
  m.first = scans_++ == 0;
  m.gap = stamp && last_stamp_ ? *stamp - *last_stamp_ : 0.0;
  if (odometry && last_odometry_) { // the odometry step (paper Sec. II)
    m.step = last_odometry_->inverse() * *odometry;
    // The sweep is at the step's end: deskewed at the velocity there, not the step's mean.
    m.sweep = sweepMotion(
        odometry_step_ ? extrapolateMotion(m.step, m.gap, *odometry_step_, odometry_span_)
                       : m.step,
        m.gap,
        sweep_period_);
    odometry_step_ = m.step;
    odometry_span_ = m.gap;
  }
  else { // constant velocity (KISS-ICP Sec. III-B), per second where there are stamps
    m.step = m.gap > 0.0 && velocity_span_ > 0.0
                 ? interpolateMotion(velocity_,
                                     std::clamp(m.gap / velocity_span_,
                                                1.0 / kMaxVelocityScale,
                                                kMaxVelocityScale))
                 : velocity_;
    m.sweep = sweepMotion(m.step, m.gap, sweep_period_);
  }
  if (odometry)
    last_odometry_ = odometry;
  m.pose = m.first ? (odometry ? *odometry : Pose::Identity()) : Pose(pose_ * m.step);
  return m;
}

Pose
MotionModel::stepTo(const Pose& matched, const MotionPrediction& m) const
{
  return m.first ? Pose::Identity() : Pose(pose_.inverse() * matched);
}

Pose
MotionModel::sweepOfMatch(const Pose& matched, const MotionPrediction& m) const
{
  const Pose step(pose_.inverse() * matched);
  return sweepMotion(scans_ > 2 ? extrapolateMotion(step, m.gap, velocity_, velocity_span_)
                                : step,
                     m.gap,
                     sweep_period_);
}

Pose
MotionModel::sweepOf(const Pose& velocity, const MotionPrediction& m) const
{
  return sweepMotion(velocity, m.gap, sweep_period_);
}

void
MotionModel::update(const Pose& matched, const MotionPrediction& m, std::optional<double> stamp)
{
  velocity_ = stepTo(matched, m);
  if (velocity_.topRightCorner<3, 1>().norm() >= min_step_)
    heading_ = velocity_.topRightCorner<3, 1>().normalized();
  velocity_span_ = m.gap;
  last_stamp_ = stamp;
  pose_ = matched;
}

void
MotionModel::applyCorrection(const Pose& correction)
{
  pose_ = orthonormalized(correction * pose_);
}

} // namespace slam
} // namespace pcl_parallel
