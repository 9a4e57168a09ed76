/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <string>

namespace pcl_parallel {
namespace io {

/** Reads the vertices (x, y, z) of an ASCII PLY file as an unorganised cloud.
 *
 * Small and strict on purpose: the Stanford scans carry a `range_grid` list element after
 * the vertices, which pcl::io::loadPLYFile turns into an organised 512x400 cloud full of
 * NaNs; here every element other than `vertex` is ignored, and so are vertex properties
 * other than x, y, z (any scalar type, in any order). Throws std::runtime_error naming
 * the file for binary PLY, a missing x/y/z property or a malformed or short vertex list. */
pcl::PointCloud<pcl::PointXYZ>::Ptr
loadAsciiPlyVertices(const std::string& path);

} // namespace io
} // namespace pcl_parallel
