/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * What a run's input and result suggest its user look at, as sentences: pcl_pslam prints
 * them, and any other caller of mapDirectory can.
 */
#pragma once

#include <pcl_parallel/slam/mapping.h>

#include <string>
#include <vector>

namespace pcl_parallel {
namespace slam {

/** A sentence about a run. */
struct Finding {
  std::string text;           ///< one sentence, no newline
  bool input_suspect = false; ///< the input is likely wrong (pcl_pslam: a warning on stderr)
};

/** Stamps a median of more than this many seconds apart are keyframes, not sweeps: slower
 *  than any spinning LiDAR turns. */
constexpr double kMaxSweepSeconds = 0.25;

/** What deskewing did (by the points' times, by azimuth, or both) for `scans` scans of which
 *  `timed_scans` carry per-point times, or a hint that they carry them; empty: nothing. */
std::string
deskewNote(std::size_t timed_scans, std::size_t scans, bool deskew);

/** Without a sweep period, deskewing takes the step since the previous scan as one sweep:
 *  a warning (else empty) where `stamps` lie a median of more than kMaxSweepSeconds apart,
 *  keyframes each bent by its whole step. */
std::string
keyframeWarning(const std::vector<double>& stamps, const DeskewParameters& deskew);

/** The result's findings, scans named by `numbers` (one per scan): matches placed by the
 *  pose search, odometry the scans contradict (kOdometryDisagreementLimit), and the steps
 *  loop closing disagreed with most (notableSequenceSteps). */
std::vector<Finding>
findings(const MappingResult& result, const std::vector<int>& numbers);

} // namespace slam
} // namespace pcl_parallel
