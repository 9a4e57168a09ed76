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

/** Time of a point within its sweep, in [0, 1], for a spinning LiDAR that turns
 *  clockwise and starts facing backwards (KITTI's Velodyne; KISS-ICP derives KITTI's
 *  timestamps the same way): t = (1 - atan2(y, x) / pi) / 2, 0.5 facing forwards. */
inline double
sweepTime(const PointT& p)
{
  return 0.5 * (1.0 - std::atan2(static_cast<double>(p.y), static_cast<double>(p.x)) / M_PI);
}

/** Pose at fraction s of a relative motion (s = 1: the motion; rotation about its axis,
 *  translation along a straight line). */
Pose
interpolateMotion(const Pose& motion, double s);

/**
 * \brief Removes the skew of a scan taken while moving (KISS-ICP's deskewing, Vizzo et
 * al. 2023, Sec. III-A): each point, measured in the scanner frame at its sweep time t,
 * is moved into the frame at mid-sweep, assuming the scanner moved by `motion` (the
 * relative pose from one mid-sweep to the next) at constant velocity over the sweep:
 * p' = motion^(t - 1/2) p. Parallel; the result is the same for any thread count.
 */
Cloud::Ptr
deskew(const Cloud& scan, const Pose& motion, unsigned num_threads = 0);

} // namespace slam
} // namespace pcl_parallel
