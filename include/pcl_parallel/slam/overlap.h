/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/types.h>

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace pcl_parallel {
namespace slam {

/** Fraction of the points of `source`, moved by `pose`, that have a point of
 *  `target` within max_distance: how much of one scan another sees (3DTK's minimum
 *  overlap). Loop links are kept by it, and the front end's pose search decides by it
 *  when to search and which candidate wins. 0 for an empty source. */
double
overlap(const Cloud& source, const Pose& pose, const KdTreeIndex& target, double max_distance);

/**
 * \brief What a scan saw through: per direction from its origin (the scanner), the range
 * of its nearest point. A point of another scan that lies well in front of it, in space the
 * beams crossed unobstructed, contradicts the pose that put it there (free-space
 * consistency). Where a site repeats (corridors, rooms of one size) a shifted match can
 * overlap a scan more than the true one does, but it puts walls into the other scan's
 * open space (docs/design.md, "Where the site repeats").
 */
class FreeSpace {
public:
  /** Directions binned by `bin` radians in azimuth about `up` and in elevation; a scan in
   *  its own frame (its origin the scanner's). Throws std::invalid_argument for a bin
   *  below kMinBin or not finite, or a zero or non-finite `up`. */
  FreeSpace(const Cloud& scan, const Eigen::Vector3d& up, double bin = kDefaultBin);

  /** Fraction of `source`'s points, moved by `pose` into the scan's frame, that lie more
   *  than `margin` nearer the scanner than the scan's nearest point in their direction
   *  and the eight around it (directions without a point count as not seen). 0 for an
   *  empty source; throws std::invalid_argument for a negative or NaN margin. */
  double
  conflicts(const Cloud& source, const Pose& pose, double margin) const;

  /** One degree: at 10 m, 17 cm across, about a reduced scan's point spacing. */
  static constexpr double kDefaultBin = 0.017453292519943295;
  /** The finest bin: 6,284 x 3,142 directions, 79 MB. */
  static constexpr double kMinBin = 0.001;

private:
  /** Each seen bin's range becomes the nearest of it and its eight neighbours. */
  void
  seenAround();
  /** The bin of direction p, or -1 for p at the origin; `range` is p's norm. */
  long
  binOf(const Eigen::Vector3d& p, double& range) const;

  Eigen::Vector3d u_, v_, up_;
  int azimuths_ = 0, elevations_ = 0;
  std::vector<float> nearest_; ///< per bin; +inf where the scan has no point
};

/** The larger share of either scan's points in the space the other saw through (FreeSpace,
 *  directions binned about `up`), with b moved into a's frame by `b_in_a`: how much a
 *  relative pose of two scans contradicts what they saw. */
double
mutualConflicts(const Cloud& a,
                const Cloud& b,
                const Pose& b_in_a,
                const Eigen::Vector3d& up,
                double margin);

} // namespace slam
} // namespace pcl_parallel
