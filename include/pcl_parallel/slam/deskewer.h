/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/types.h>

#include <utility>
#include <vector>

namespace pcl_parallel {
namespace slam {

/**
 * \brief Undoes a spinning LiDAR's motion during its sweep (deskewSweep: by the points'
 * sweep times where given, else by azimuth). The first scan comes before any motion is
 * known: the deskewer keeps it as given until the first step is (docs/design.md, "The
 * first scan"). Off (`enabled` false), a scan passes unchanged.
 */
class Deskewer {
public:
  /** `clockwise`: the head's turn seen from +z (sweepTime); `voxel_size`: the reduction's,
   *  the unit of needsAgain's threshold. */
  Deskewer(bool enabled, bool clockwise, double voxel_size, unsigned num_threads);

  /** True when deskewing is on. */
  bool
  enabled() const
  {
    return enabled_;
  }

  /** The scan in the scanner's frame at mid-sweep, its motion during the sweep
   *  undone; a copy when deskewing is off. */
  Cloud::Ptr
  deskew(const Cloud& scan, const std::vector<float>& sweep_times, const Pose& sweep) const;

  /** The scan's points' sweep times: `sweep_times` where given, else each point's from its
   *  azimuth (sweepTime, turning `clockwise`). */
  std::vector<float>
  sweepTimesOf(const Cloud& scan, const std::vector<float>& sweep_times) const;

  /** The scan's raw points nearest their voxels' centroids (voxelNearestToCentroid at
   *  `voxel_size`) with their sweep times (`times`, one per point of the scan): what a
   *  sweep path is fitted to (SweepPath). */
  std::pair<Cloud::Ptr, std::vector<float>>
  timedSample(const Cloud& scan, const std::vector<float>& times, double voxel_size) const;

  /** Points deskewed by `from` by their azimuths (a registered sample, whose raw points
   *  are gone), deskewed by `to` instead (redeskew); a copy where deskewing is off. */
  Cloud::Ptr
  again(const Cloud& deskewed, const Pose& from, const Pose& to) const;

  /** Keeps the sequence's first scan until the first step is known (when enabled). */
  void
  holdFirst(const Cloud& scan, const std::vector<float>& sweep_times);
  /** True while the first scan is held until the first step is known. */
  bool
  holdsFirst() const
  {
    return static_cast<bool>(first_);
  }
  /** The held first scan deskewed by `sweep`, no longer held. */
  Cloud::Ptr
  releaseFirst(const Pose& sweep);

  /** Whether deskewing by `matched` instead of `predicted` moves the reduced scan's
   *  farthest point by more than half a voxel: a scan taken while the motion changed (a
   *  turn begun or ended) is then deskewed again by its matched step. */
  bool
  needsAgain(const Pose& predicted, const Pose& matched, const Cloud& reduced) const;
  /** Whether deskewing by `b` instead of `a` moves the reduced scan's farthest point by
   *  more than `distance` (to first order). */
  static bool
  movesBeyond(const Pose& a, const Pose& b, const Cloud& reduced, double distance);

private:
  bool enabled_;
  bool clockwise_;
  double voxel_size_;
  unsigned num_threads_;
  Cloud::Ptr first_;               ///< the first scan as given, until the first step is known
  std::vector<float> first_times_; ///< its points' sweep times, if given
};

} // namespace slam
} // namespace pcl_parallel
