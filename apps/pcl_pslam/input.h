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

#include <pcl_parallel/io/scan_directory.h>

#include <string>
#include <vector>

namespace pcl_pslam {

/** What `run` reads: the selected scan files with their initial poses and timestamps
 *  (io::openScanDirectory), and what the run learns of them. The scans themselves are
 *  read one at a time (io::readScan), as the pipeline needs them. */
struct Input : pcl_parallel::io::ScanDirectory {
  Poses truth;               ///< the simulation's truth (demo), else empty
  double read_seconds = 0.0; ///< time spent reading scans (by this rank; filled by the caller)
  /** Scans whose per-point times span a sweep (likewise; without --deskew only the first
   *  scan is looked at). */
  std::size_t timed_scans = 0;
};

/** The options io::openScanDirectory takes: the one place the command line maps onto. */
pcl_parallel::io::ScanDirectoryOptions
toScanDirectoryOptions(const Options& o);

/** io::openScanDirectory(toScanDirectoryOptions(o)), with --out refused where it is the
 *  scan directory. Throws UsageError for what the command line asks that cannot be met
 *  (io::ScanDirectoryUsageError), DataError naming the file (and line) for bad data. */
Input
openDirectory(const Options& o);

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

/** `demo`: simulates o.preset and writes it to o.keep (or a new temporary folder) in the
 *  app's formats; points o.dir (and, for a sweep taken while moving, o.poses_file and
 *  o.deskew) at it, so the scans are read as `run` reads them. Returns the folder. */
std::string
simulateDemo(Options& o);

} // namespace pcl_pslam
