/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * CARMEN log files (.clf, and .clf.bz2 read through bzip2): the 2D laser logs of the
 * Freiburg SLAM evaluation (Kümmerle et al., Autonomous Robots 27(4), 2009) and of Radish.
 * A laser line becomes a scan in the laser's frame (x forward, y left, z = 0) with the
 * laser's and the robot's odometry poses: the paper's 3-DOF special case.
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <cstddef>
#include <map>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace io {

/** How loadCarmenLog reads the ranges. */
struct CarmenReadOptions {
  /** A reading at or beyond this is "no return" and dropped (metres). The Radish logs
   *  saturate at 81.83 m (intel) and 81.91 m (fr079, mit-csail) and hold no real reading
   *  beyond 42.4 m; their README says: readings of 80 m or more are invalid. A smaller
   *  maximum the log states (PARAM robot_front_laser_max, ROBOTLASER1's maximum_range)
   *  applies too. */
  double max_range = 80.0;
  /** A reading below this is dropped (metres); a reading of 0 or less always is (CARMEN
   *  drivers write 0 for a beam without echo). */
  double min_range = 0.0;
};

/** Which CARMEN message a scan came from. */
enum class CarmenLaserMessage {
  FLaser,     ///< FLASER: the front laser, angles by CARMEN's rule
  RobotLaser1 ///< ROBOTLASER1: angles, field of view and maximum range on the line
};

/** One laser line. Poses are planar (x, y, θ as a 4x4 rotation about z, z = 0), p_frame =
 *  T·p. Non-template and copyable; the cloud is shared. */
struct CarmenScan {
  CarmenLaserMessage message = CarmenLaserMessage::FLaser; ///< the line's message type
  double timestamp = 0.0;        ///< ipc_timestamp (s): when the scan was taken
  double logger_timestamp = 0.0; ///< seconds since the logger started
  std::size_t line = 0;          ///< the line of the log (from 1), for messages
  /** The laser's pose in the odometry frame. */
  Eigen::Matrix4d laser_pose = Eigen::Matrix4d::Identity();
  /** The robot's (odometry) pose at the scan. */
  Eigen::Matrix4d robot_pose = Eigen::Matrix4d::Identity();
  /** The laser on the robot: robot_pose⁻¹ · laser_pose (fr079: x = -0.04 m, as its PARAM
   *  robot_frontlaser_offset). */
  Eigen::Matrix4d laser_offset = Eigen::Matrix4d::Identity();
  std::size_t beams = 0;           ///< readings on the line, kept or not
  double start_angle = 0.0;        ///< angle of beam 0 (rad, counter-clockwise from x)
  double angular_resolution = 0.0; ///< angle between beams (rad)
  double max_range = 0.0;          ///< the limit applied: readings at or beyond were dropped
  /** The kept readings as points in the laser's frame, beam order, z = 0. */
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud;
};

/** An ODOM line: the robot's odometry pose and velocities. */
struct CarmenOdometry {
  double timestamp = 0.0;        ///< ipc_timestamp (s)
  double logger_timestamp = 0.0; ///< seconds since the logger started
  std::size_t line = 0;          ///< the line of the log (from 1)
  /** The robot's pose (planar, z = 0). */
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  double tv = 0.0;    ///< translational velocity (m/s)
  double rv = 0.0;    ///< rotational velocity (rad/s)
  double accel = 0.0; ///< acceleration
};

/** A PARAM line: a CARMEN parameter as text. */
struct CarmenParam {
  std::string name;     ///< the parameter
  std::string value;    ///< its value
  std::size_t line = 0; ///< the line of the log (from 1)
};

/** A whole log, in file order (which is not time order in every log: sort by timestamp
 *  where order matters). */
struct CarmenLog {
  std::vector<CarmenScan> scans;              ///< FLASER and ROBOTLASER1 lines
  std::vector<CarmenOdometry> odometry;       ///< ODOM lines
  std::vector<CarmenParam> params;            ///< PARAM lines
  std::map<std::string, std::size_t> skipped; ///< other messages (RLASER, TRUEPOS, ...) by name
  std::size_t lines = 0; ///< the last line that holds more than white space
};

/** Reads a CARMEN log: `.bz2` by its extension through a bzip2 decompressor, any other
 *  name as text. Messages: FLASER, ROBOTLASER1, ODOM and PARAM; lines starting with '#'
 *  are comments; other messages (a name of capitals, digits and '_') are counted in
 *  `skipped`. FLASER beam i lies at -90° + i·res (CARMEN's readlog.c: start -π/2,
 *  res = PARAM laser_front_laser_resolution in degrees where the log has it, else
 *  carmenGuessAngleIncrement); ROBOTLASER1 carries its own start and resolution. A reading
 *  is dropped when it is not finite (the scans' rule: a no-return), at most 0, below
 *  min_range, or at or beyond the maximum range (see CarmenReadOptions). Throws
 *  std::runtime_error "pcl_parallel::io: FILE:LINE: what" where a line is malformed (a
 *  known message with the wrong field count or a field that is no number, a pose or time
 *  stamp that is not finite, as in the pose files; a first field that is no message name)
 *  or the file cannot be read (a corrupt bzip2 stream among them), and when the file holds
 *  no message at all. Lines as every text reader: "\n", "\r\n" or "\r", 64 KiB at most. */
CarmenLog
loadCarmenLog(const std::string& path, const CarmenReadOptions& options = {});

/** CARMEN's carmen_laser_guess_fov (readlog.c): the field of view (rad) of a SICK scan
 *  of `beams` readings: 180 beams 179°, 181 180°, 360 179.5°, 361 180°, 400 99.75°,
 *  401 100°, else 180°. */
double
carmenGuessFov(std::size_t beams);

/** CARMEN's carmen_laser_guess_angle_increment (readlog.c): 180 or 181 beams 1°, 360 or
 *  361 0.5°, 400 or 401 0.25°, else carmenGuessFov(beams) / (beams - 1) (rad). */
double
carmenGuessAngleIncrement(std::size_t beams);

/** The planar pose (x, y, θ) as a 4x4 matrix: rotation θ about z, z = 0. */
Eigen::Matrix4d
planarPose(double x, double y, double theta);

} // namespace io
} // namespace pcl_parallel
