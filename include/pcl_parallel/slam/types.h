/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace pcl_parallel {
class KdTreeIndex;

namespace slam {

/** The mapping pipeline works on xyz points; poses are double from input to output. */
using PointT = pcl::PointXYZ;
/** A scan or reduced scan. */
using Cloud = pcl::PointCloud<PointT>;
/** Map points carry the normal estimated once, in the scan they came from. */
using MapPoint = pcl::PointNormal;
/** A map cloud with normals. */
using MapCloud = pcl::PointCloud<MapPoint>;
/** A scan's pose: p_world = pose * p_scan. */
using Pose = Eigen::Matrix4d;
/** One pose per scan. */
using Poses = std::vector<Pose>;
/** Inverse covariance of a pose error (translation, rotation vector) in the scan's frame
 *  (lum::PoseConstraint). */
using Information = Eigen::Matrix<double, 6, 6>;

/** An edge of the pose graph: scan `target` < scan `source`; `loop` is false for the
 *  front end's consecutive pairs. */
struct Link {
  /** The link's target (older) scan. */
  std::uint32_t target = 0;
  /** The link's source (newer) scan. */
  std::uint32_t source = 0;
  /** True for a loop link (not consecutive scans). */
  bool loop = false;
};

} // namespace slam
} // namespace pcl_parallel
