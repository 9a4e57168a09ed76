/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pcl_pslam's input: a directory of scans (with odometry, poses and timestamps) or the
 * built-in simulated set, checked so that every problem is one line naming the file.
 */
#pragma once

#include "options.h"
#include "slam_pipeline.h"

#include <functional>
#include <limits>
#include <string>
#include <vector>

namespace pcl_pslam {

/** What `run` reads: the selected scan files with their initial poses and timestamps.
 *  The scans themselves are read one at a time (readScan), as the pipeline needs them. */
struct Input {
  Poses initial; ///< odometry, or identities when `odometry` is false
  bool odometry = true;
  Poses truth;                    ///< the simulation's truth (demo), else empty
  std::vector<std::string> files; ///< per scan: its file
  std::vector<int> numbers;       ///< per scan: its number (-s/-e count in these)
  std::vector<double> stamps;     ///< per scan: time (s), or the number when none given
  bool has_stamps = false;
  double read_seconds = 0.0; ///< time spent reading scans (by this rank; filled by the caller)
  /** Scans whose per-point times span a sweep (likewise; without --deskew only the first
   *  scan is looked at). */
  std::size_t timed_scans = 0;
  std::string format;       ///< "3d", "bin", ...
  double scale = 1.0;       ///< file coordinates times scale = metres
  int up = 2;               ///< vertical axis
  bool frames_3dtk = false; ///< data in 3DTK's frame and units: .frames in those
  double min_range = 0.0;   ///< -M, files' units
  double max_range = std::numeric_limits<double>::infinity(); ///< -m, files' units

  std::size_t
  size() const
  {
    return files.size();
  }
};

/** The scan files of o.dir selected by -s/-e, their initial poses and timestamps; no scan
 *  is read yet. Throws UsageError for a directory that does not exist, a poses/times file
 *  that does not exist or -s/-e that select fewer than 2 scans, DataError naming the file
 *  (and line) for bad data: no scans, a bad .pose file, a poses or times file whose line
 *  count differs from the number of scan files. */
Input
openDirectory(const Options& o);

/** Scan k of `in`, in metres, within the range limits; with `point_times`, the points'
 *  times from the file's time field (io::loadScan), or none. Throws DataError naming the
 *  file when it cannot be parsed, has no finite points within the limits, or (with
 *  `point_times`) a kept point's time is not finite. */
Cloud::Ptr
readScan(const Input& in, std::size_t k, std::vector<double>* point_times = nullptr);

/** What the run did about deskewing, from in.timed_scans (counted as the scans were
 *  read): by the points' times, by azimuth, or both; without deskewing, a hint when the
 *  first scan carries per-point times. Empty: nothing to say. */
std::string
deskewNote(const Input& in, bool deskew);

/** Deskewing takes the motion since the previous scan as one sweep's unless told the
 *  sweep period. A warning (else empty) when `deskew` is on without a sweep_period and
 *  the scans' time stamps lie a median of more than kMaxSweepSeconds apart, longer than
 *  any spinning LiDAR's sweep (4 Hz): keyframes, each bent by its whole step. */
std::string
keyframeWarning(const Input& in, bool deskew, double sweep_period);
constexpr double kMaxSweepSeconds = 0.25;

/** Every scan of `in` (small sets and tests; `run` streams them). */
std::vector<Cloud::Ptr>
readAllScans(const Input& in);

/** The demo's simulated scan set (metres, z up, odometry and truth). */
/** `demo`: simulates o.preset and writes it to o.keep (or a new temporary folder) in the
 *  app's formats; points o.dir (and, for a sweep taken while moving, o.poses_file and
 *  o.deskew) at it, so the scans are read as `run` reads them. Returns the folder. */
std::string
simulateDemo(Options& o);

} // namespace pcl_pslam
