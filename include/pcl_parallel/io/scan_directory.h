/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

/* A directory of scans as 3DTK's slam6D and KITTI lay them out: the scan files of one
 * format, numbered by their names, with odometry (3DTK .pose files beside the scans, or a
 * KITTI / TUM poses file) and time stamps (times.txt), checked so that every problem is
 * one message naming the file. The scans themselves are read one at a time (readScan).
 * A 2D laser log (CARMEN .clf, .clf.bz2) is opened as such a directory: its laser scans
 * taken where the robot moved or turned enough, with their odometry and time stamps. */

namespace pcl_parallel {
namespace io {

/** A request the directory cannot meet: no such directory or poses/times file, -s/-e
 *  selecting fewer than 2 scans, two formats equally common. The caller's mistake. */
struct ScanDirectoryUsageError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

/** Bad data: no scans, a scan or pose file that cannot be parsed, counts that do not
 *  match. The message names the file (and line). */
struct ScanDataError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/** What to read of a directory. Lengths in the files' units. */
struct ScanDirectoryOptions {
  /** The directory of scans. */
  std::string dir;
  /** KITTI or TUM odometry (detectPoseFileFormat), one pose per scan file of the
   *  directory (before -s/-e); "": odometry.txt in dir where there is one (as `pcl_pslam
   *  simulate` writes it; not with no_poses), else the .pose files beside 3DTK .3d scans,
   *  else none. */
  std::string poses_file;
  /** One time stamp (s) per scan file; "": times.txt in dir or its parent (KITTI's
   *  sequences/NN/ beside velodyne/), which is then the scans' and must have as many. */
  std::string times_file;
  std::string format;     ///< scan extension; "": the most common (.txt only when named)
  int first = 0;          ///< -s: first scan number
  int last = -1;          ///< -e: last scan number, inclusive (-1: all)
  double min_range = 0.0; ///< -M
  double max_range = std::numeric_limits<double>::infinity(); ///< -m
  std::optional<double> scale; ///< coordinates times this are metres (default: .3d 0.01)
  int up = -1;                 ///< vertical axis (-1: .3d y, else z)
  bool no_poses = false;       ///< ignore odometry.txt and the .pose files beside .3d scans
  /** A CARMEN log (`dir` names a .clf or .clf.bz2 file): a laser scan is kept where the
   *  odometry moved at least min_travel (m) or turned at least min_turn (rad) since the
   *  last scan kept, the first scan always. 0 and 0: every scan. */
  double min_travel = 0.2;
  double min_turn = 10.0 * M_PI / 180.0; ///< rad; see min_travel
};

/** The selected scan files of a directory with their initial poses and time stamps. */
struct ScanDirectory {
  std::vector<Eigen::Matrix4d> initial; ///< odometry (metres), or identities
  bool odometry = true;                 ///< false: `initial` holds identities
  std::string poses_file;         ///< the odometry's file (the options' or odometry.txt), or ""
  std::vector<std::string> files; ///< per scan: its file
  std::vector<int> numbers;       ///< per scan: its number (-s/-e count in these)
  std::vector<double> stamps;     ///< per scan: time (s), or the number when none given
  /** True when the time stamps came from a file (times.txt, --times, a TUM file). */
  bool has_stamps = false;
  std::string format;       ///< "3d", "bin", ...
  double scale = 1.0;       ///< file coordinates times scale = metres
  int up = 2;               ///< vertical axis
  bool frames_3dtk = false; ///< data in 3DTK's frame and units: .frames in those
  double min_range = 0.0;   ///< files' units
  double max_range = std::numeric_limits<double>::infinity(); ///< files' units
  /** 2D scans (slam::Parameters::planar): every point of the first scan lies in the
   *  scanner's x-y plane, `up` being z (a CARMEN log's always do). */
  bool planar = false;
  /** A log's scans, read with it (readScan returns copies); empty for a directory. */
  std::vector<pcl::PointCloud<pcl::PointXYZ>::Ptr> clouds;
  /** A log's laser scans before the selection by motion (0: a directory). */
  std::size_t log_scans = 0;

  /** Number of selected scans. */
  std::size_t
  size() const
  {
    return files.size();
  }
};

/** The scan files of o.dir selected by first/last, sorted as a user numbered them
 *  (scan2 before scan10, as 3DTK's scanNNN; else by name), numbered by the numbers in
 *  their names where every file has a distinct one (else their positions), with their
 *  initial poses and time stamps; only the first scan is read (is it 2D?). Where o.dir
 *  names a CARMEN log (isCarmenLogName): its laser scans in time order, numbered from 0,
 *  selected by first/last and then by motion (min_travel, min_turn), each with the
 *  laser's odometry pose and its time stamp; poses_file, times_file, format, scale and up
 *  do not apply to it. Throws ScanDirectoryUsageError or ScanDataError (above). */
ScanDirectory
openScanDirectory(const ScanDirectoryOptions& o);

/** True for a CARMEN log's name: .clf or .clf.bz2 (any case). */
bool
isCarmenLogName(const std::string& path);

/** Scan k of `in`, in metres, within the range limits; with `point_times`, the points'
 *  times from the file's time field (loadScan), or none. Throws ScanDataError naming the
 *  file when it cannot be parsed, has no finite points within the limits, is not in its
 *  scanner's frame (slam::requireScannerFrame) or (with `point_times`) a kept point's
 *  time is not finite. */
pcl::PointCloud<pcl::PointXYZ>::Ptr
readScan(const ScanDirectory& in, std::size_t k, std::vector<double>* point_times = nullptr);

/** Every scan of `in` (small sets and tests; a pipeline streams them). */
std::vector<pcl::PointCloud<pcl::PointXYZ>::Ptr>
readAllScans(const ScanDirectory& in);

} // namespace io
} // namespace pcl_parallel
