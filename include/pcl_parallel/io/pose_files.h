/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

#include <functional>
#include <string>
#include <vector>

/* Trajectory files: KITTI (poses/NN.txt), TUM (evo's and most SLAM evaluations' format) and
 * 3DTK's .frames. Every reader throws std::runtime_error "pcl_parallel::io: FILE:LINE: what"
 * for a file it cannot read or parse; every writer writes a temporary file beside the target
 * and renames it, so a target is either complete or untouched. Numbers are read and written
 * independently of the locale; written in the shortest form that reads back exactly. */

namespace pcl_parallel {
namespace io {

/** The trajectory file formats: KITTI (12 numbers a line), TUM (stamp, position, quaternion),
 *  3DTK .frames. */
enum class PoseFileFormat { Kitti, Tum, Frames };

/** "kitti", "tum", "frames". */
std::string
toString(PoseFileFormat format);

/** 3DTK's unit: centimetres. The frames functions take "unit", the metres per file unit:
 *  translations are multiplied by it when read and divided by it when written (rotations
 *  are kept: like the app, we work in 3DTK's own left-handed, y-up frame, only scaled). */
constexpr double kFramesUnit = 0.01;

///@{
/** 3DTK's frame type codes (Scan::AlgoType), which its viewer colours. */
constexpr int kFramesInvalid = 0, kFramesIcp = 1, kFramesIcpInactive = 2, kFramesLum = 3;
///@}

/** A pose file's pose is a rigid motion: its rotation orthonormal within this (every
 *  entry of R^T R - I), det R > 0, last row 0 0 0 1. */
constexpr double kRigidMotionTolerance = 1e-3;
/** ... and lies within this of the origin (in metres: no trajectory on Earth lies beyond). */
constexpr double kMaxPoseTranslation = 1e9;

/** Why `pose` is no pose a file may give (not finite, not a rigid motion, too far: the
 *  bounds above), as the end of a sentence ("is not finite"); empty for a pose. */
std::string
poseProblem(const Eigen::Matrix4d& pose);

/** A trajectory as read from a file: poses (p_world = T·p), and one timestamp per pose (in
 *  seconds) where the format has them (TUM), else none. */
struct Trajectory {
  /** The poses, p_world = T·p. */
  std::vector<Eigen::Matrix4d> poses;
  /** One time stamp (s) per pose where the format has them (TUM), else empty. */
  std::vector<double> timestamps;
  /** The format the file was read as. */
  PoseFileFormat format = PoseFileFormat::Kitti;
};

/** Writes KITTI pose lines (12 numbers: the 3x4 [R|t], row-major), read by loadKittiPoses. */
void
writeKittiPoses(const std::string& path, const std::vector<Eigen::Matrix4d>& poses);

/** Reads KITTI odometry's times.txt: one timestamp (seconds) a line, blank lines skipped;
 *  a line with anything but one finite number is an error. */
std::vector<double>
loadKittiTimes(const std::string& path);

/** Reads a TUM trajectory: per line "timestamp tx ty tz qx qy qz qw" (Sturm et al., TUM
 *  RGB-D benchmark; evo's file_interface), blank lines and lines starting with '#' skipped.
 *  The quaternion is normalised; a line whose quaternion norm is not within 1 ± 0.01 (a
 *  column missing or in another order) is an error, as is any line without exactly 8
 *  finite numbers. */
Trajectory
loadTumTrajectory(const std::string& path);

/** Writes a TUM trajectory (with a "# timestamp tx ty tz qx qy qz qw" header line).
 *  Without timestamps, pose i gets timestamp i; otherwise one per pose is required
 *  (std::invalid_argument). */
void
writeTumTrajectory(const std::string& path,
                   const std::vector<Eigen::Matrix4d>& poses,
                   const std::vector<double>& timestamps = {});

/** Reads every line of one 3DTK .frames file (one scan's pose history, 16 numbers of the
 *  4x4 matrix in column-major order, then a type code; the last line is the final pose).
 *  Every line is checked (a garbled line in the middle is an error too). */
std::vector<Eigen::Matrix4d>
loadFrames(const std::string& path, double unit = kFramesUnit);

/** The final pose of a .frames file in the file's units: loadFrames(path, 1.0).back(). */
Eigen::Matrix4d
loadFramesFinalPose(const std::string& path);

/** One line of a .frames file: a pose and its type code. */
struct Frame {
  /** The pose (4x4). */
  Eigen::Matrix4d pose;
  /** Its 3DTK type code (kFramesIcp, kFramesLum, ...). */
  int type = kFramesIcp;
};

/** Writes one .frames file, one line per frame (the last is the final pose), translations
 *  divided by `unit`. Numbers in the shortest form that reads back exactly, or with
 *  `digits` > 0 that many significant digits (printf's %.*g in the C locale). */
void
writeFrames(const std::string& path,
            const std::vector<Frame>& frames,
            double unit = kFramesUnit,
            int digits = 0);

/** writeFrames with every pose of the history under one type code. */
void
writeFrames(const std::string& path,
            const std::vector<Eigen::Matrix4d>& history,
            double unit = kFramesUnit,
            int type = kFramesIcp);

/** One scan's .frames as slam6D leaves it: the initial pose (kFramesInvalid), after ICP
 *  (kFramesIcp), the final pose (kFramesLum); a scan held fixed kFramesIcpInactive after
 *  the first. 12 significant digits, translations divided by `unit`. */
void
writeScanFrames(const std::string& path,
                const Eigen::Matrix4d& initial,
                const Eigen::Matrix4d& icp,
                const Eigen::Matrix4d& final_pose,
                bool fixed,
                double unit);

/** The poses a mapping run leaves in dir: scanNNN.frames per scan (writeScanFrames, NNN =
 *  numbers[i] with 3 digits at least, the first scan held fixed; `each` after every file),
 *  then the final and the front end's poses as poses.txt, poses_icp.txt (KITTI) and
 *  poses_tum.txt, poses_icp_tum.txt (TUM at `stamps`). Returns the names, scanNNN.frames
 *  for the lot. */
std::vector<std::string>
writeRunPoses(const std::string& dir,
              const std::vector<int>& numbers,
              const std::vector<Eigen::Matrix4d>& initial,
              const std::vector<Eigen::Matrix4d>& icp,
              const std::vector<Eigen::Matrix4d>& final_poses,
              const std::vector<double>& stamps,
              double frames_unit,
              const std::function<void()>& each = {});

/** The final poses of the scanNNN.frames files in a directory, in scan-number order (files
 *  not named scanNNN.frames after them, by name), as a trajectory. Throws when the directory
 *  holds no .frames file. */
std::vector<Eigen::Matrix4d>
loadFramesDirectory(const std::string& dir, double unit = kFramesUnit);

/** Writes scanNNN.frames (NNN = first_index + i, 3 digits at least, as 3DTK) into an
 *  existing directory, one line (the final pose) per file. */
void
writeFramesDirectory(const std::string& dir,
                     const std::vector<Eigen::Matrix4d>& poses,
                     double unit = kFramesUnit,
                     int type = kFramesIcp,
                     std::size_t first_index = 0);

/** The format of a pose file or directory: a directory is 3DTK .frames; a file is TUM by
 *  the extension .tum, KITTI by .kitti, else by its first line that is neither blank nor a
 *  '#' comment: 8 numbers TUM, 12 KITTI. Throws std::runtime_error naming the path (and
 *  line) when it is missing or none of these (e.g. a single .frames file: pass its
 *  directory). */
PoseFileFormat
detectPoseFileFormat(const std::string& path);

/** Reads a trajectory in any of the formats above (detectPoseFileFormat). */
Trajectory
loadTrajectory(const std::string& path, double frames_unit = kFramesUnit);

} // namespace io
} // namespace pcl_parallel
