/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Per-scan preprocessing before matching: range crop and deskewing.
 */
#pragma once

#include <pcl_parallel/slam/types.h>

#include <cmath>

namespace pcl_parallel {
namespace slam {

/** The finite points whose distance from the scanner lies in [min_range, max_range]. */
Cloud::Ptr
cropRange(const Cloud& scan, double min_range, double max_range);

/** Time of a point within its sweep, in [0, 1], for a spinning LiDAR that starts facing
 *  backwards (-x) and turns clockwise seen from +z (KITTI's Velodyne; KISS-ICP derives
 *  KITTI's timestamps the same way): t = (1 - atan2(y, x) / pi) / 2, 0.5 facing forwards;
 *  counter-clockwise: 1 - t. */
inline double
sweepTime(const PointT& p, bool clockwise = true)
{
  const double a = std::atan2(static_cast<double>(p.y), static_cast<double>(p.x)) / M_PI;
  return 0.5 * (clockwise ? 1.0 - a : 1.0 + a);
}

/** Pose at fraction s of a relative motion (s = 1: the motion; rotation about its axis,
 *  translation along a straight line). */
Pose
interpolateMotion(const Pose& motion, double s);

/** The motion during one sweep, at the constant velocity of `motion` taken over `span`
 *  seconds: motion^(sweep_period / span), at most the whole motion. A keyframe several
 *  sweeps after its predecessor is skewed by one sweep's motion, not by the whole step.
 *  sweep_period 0: the whole motion (consecutive sweeps). */
Pose
sweepMotion(const Pose& motion, double span, double sweep_period);

/**
 * \brief Removes the skew of a scan taken while moving (KISS-ICP's deskewing, Vizzo et
 * al. 2023, Sec. III-A): each point, measured in the scanner frame at its sweep time t,
 * is moved into the frame at mid-sweep, assuming the scanner moved by `motion` (the
 * relative pose from one mid-sweep to the next) at constant velocity over the sweep:
 * p' = motion^(t - 1/2) p, t = sweepTime(p, clockwise). Parallel; the result is the same for
 * any thread count.
 */
Cloud::Ptr
deskew(const Cloud& scan, const Pose& motion, unsigned num_threads = 0, bool clockwise = true);

} // namespace slam
} // namespace pcl_parallel
