/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace pcl_parallel {
namespace filters {

/**
 * \brief Voxel-grid reduction: one point per occupied voxel, the centroid of its points
 * (what pcl::VoxelGrid computes), without VoxelGrid's limit.
 *
 * pcl::VoxelGrid indexes voxels with one int32 over the cloud's bounding box and, when
 * the box holds more than 2^31 voxels (a 10 cm grid over 130 m x 130 m x 130 m), warns and
 * returns the cloud unreduced. Here each voxel is keyed by its three integer coordinates,
 * so any extent works as long as |coordinate / voxel_size| < 2^31.
 *
 * Keys are computed in parallel and radix-sorted (stable, so equal keys stay in input order);
 * each centroid is summed in double in input order. The output is in key order (x, then y, then
 * z) and bit-identical for any thread count. Non-finite points are dropped; the output is
 * dense. voxel_size <= 0 (or NaN) returns the finite points unchanged. Throws
 * std::invalid_argument when a coordinate is too far from the origin for the voxel size.
 */
pcl::PointCloud<pcl::PointXYZ>::Ptr
voxelCentroid(const pcl::PointCloud<pcl::PointXYZ>& cloud,
              double voxel_size,
              unsigned num_threads = 0);

} // namespace filters
} // namespace pcl_parallel
