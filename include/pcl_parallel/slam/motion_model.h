/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/types.h>

#include <cstddef>
#include <optional>

namespace pcl_parallel {
namespace slam {

/** What the motion model predicts for the next scan. */
struct MotionPrediction {
  Pose step = Pose::Identity();  ///< since the previous scan
  Pose sweep = Pose::Identity(); ///< during this scan's sweep: what deskewing undoes
  Pose pose = Pose::Identity();  ///< the predicted pose (world)
  double gap = 0.0;              ///< seconds since the previous scan (0: no stamps)
  bool first = false;            ///< the sequence's first scan: nothing to predict from
};

/**
 * \brief The front end's motion model: the odometry step where odometry is given (paper
 * Sec. II), else constant velocity (KISS-ICP Sec. III-B), per second where the scans have
 * time stamps. It holds the last scan's pose, which loop closing may correct.
 */
class MotionModel {
public:
  /** `sweep_period`: seconds a sweep takes (0: a scan is the whole step's sweep);
   *  `min_step`: steps shorter than this set no direction of travel. */
  MotionModel(double sweep_period, double min_step);

  /** The next scan's step, sweep and pose from its odometry pose and stamp, if known. */
  MotionPrediction
  predict(const std::optional<Pose>& odometry, std::optional<double> stamp);

  /** The step from the last pose to `matched`: the velocity update() takes (identity
   *  for the first scan). */
  Pose
  stepTo(const Pose& matched, const MotionPrediction& m) const;

  /** The sweep's motion for a scan matched at `matched` (one sweep's share of the matched
   *  step, at the velocity of the step's end, as predict's): what deskewing by the match
   *  undoes. */
  Pose
  sweepOfMatch(const Pose& matched, const MotionPrediction& m) const;

  /** The sweep's motion of one step at `velocity` over the prediction's gap. */
  Pose
  sweepOf(const Pose& velocity, const MotionPrediction& m) const;

  /** Takes the matched pose of the scan `m` predicted: velocity, heading, last pose. */
  void
  update(const Pose& matched, const MotionPrediction& m, std::optional<double> stamp);

  /** Moves the last pose by a rigid correction (loop closing). */
  void
  applyCorrection(const Pose& correction);

  /** The last pose. */
  const Pose&
  lastPose() const
  {
    return pose_;
  }
  /** The direction of the last step longer than min_step, in the scanner's frame (zero:
   *  none yet). */
  const Eigen::Vector3d&
  heading() const
  {
    return heading_;
  }
  /** Scans predicted so far. */
  std::size_t
  scans() const
  {
    return scans_;
  }

private:
  double sweep_period_;
  double min_step_;
  std::size_t scans_ = 0;
  Pose pose_ = Pose::Identity();
  Pose velocity_ = Pose::Identity(); ///< last matched step
  double velocity_span_ = 0.0;       ///< ... taken over this many seconds (0: unknown)
  Eigen::Vector3d heading_ = Eigen::Vector3d::Zero();
  std::optional<Pose> last_odometry_;
  std::optional<Pose> odometry_step_; ///< the last odometry step
  double odometry_span_ = 0.0;        ///< ... taken over this many seconds (0: unknown)
  std::optional<double> last_stamp_;
};

} // namespace slam
} // namespace pcl_parallel
