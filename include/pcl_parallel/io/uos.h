/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/io/pose_files.h> // loadFramesFinalPose: 3DTK's .frames

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <limits>
#include <string>

namespace pcl_parallel {
namespace io {

/** Reads a 3DTK "uos" scan (.3d): one point per line, "x y z" (further columns are
 *  ignored), in the scanner's frame (3DTK: centimetres, left-handed, y up). The first
 *  non-blank line may be 3DTK's grid header "W x H" and is then skipped; every other line
 *  must start with three numbers (one locale-independent parser for all our text formats,
 *  as loadXyzScan; "nan" or "inf" marks a no-return, dropped). Points whose range
 * sqrt(x²+y²+z²) lies outside [min_range, max_range] are dropped (3DTK data has out-of-range
 * returns at 3276.7 cm and near-range junk). Throws std::runtime_error naming the file and line
 * when it cannot be read, when a line is malformed, when a kept coordinate exceeds float's
 * range, or when the file holds no points at all (an empty scan file is a broken copy, not a
 * scan; a scan whose points all fall outside the range filter gives an empty cloud). */
pcl::PointCloud<pcl::PointXYZ>::Ptr
loadUosScan(const std::string& path,
            double min_range = 0.0,
            double max_range = std::numeric_limits<double>::infinity());

/** Reads a 3DTK .pose file: "x y z" then "θx θy θz" in degrees. Returns the 4x4 pose
 *  with R = Rx(θx)·Ry(θy)·Rz(θz) and p_world = R·p + t (3DTK's EulerToMatrix4).
 *  Throws std::runtime_error naming the file when unreadable, or when it does not hold
 *  exactly 6 finite numbers. */
Eigen::Matrix4d
loadUosPose(const std::string& path);

/** 3DTK's Euler convention: R = Rx(rx)·Ry(ry)·Rz(rz), angles in radians. */
Eigen::Matrix3d
eulerToRotation3dtk(double rx, double ry, double rz);

} // namespace io
} // namespace pcl_parallel
