/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

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

/**
 * \brief Voxel-grid sampling that keeps measured points: per occupied voxel, the input
 * point nearest the centroid of its points (ties: the first in input order).
 *
 * A centroid averages noise but leaves the surface wherever a voxel holds an edge, a
 * corner or a curved patch, by an amount that changes with where the scanner stood;
 * a point that was measured lies on the surface. The front end samples the points it
 * registers this way (docs/design.md, "Sampling the registered points"). Grouping, key
 * order, non-finite points, voxel_size <= 0 and the errors are as in voxelCentroid; the
 * output is the same for any thread count.
 */
pcl::PointCloud<pcl::PointXYZ>::Ptr
voxelNearestToCentroid(const pcl::PointCloud<pcl::PointXYZ>& cloud,
                       double voxel_size,
                       unsigned num_threads = 0);
/** voxelNearestToCentroid's points as their indices in `cloud`, in the same order: for
 *  callers that keep something per point beside the cloud (a point's time). */
std::vector<std::uint32_t>
voxelNearestToCentroidIndices(const pcl::PointCloud<pcl::PointXYZ>& cloud,
                              double voxel_size,
                              unsigned num_threads = 0);

/**
 * \brief voxelCentroid over a map that arrives scan by scan: memory grows with the
 * occupied voxels, not with the points (a 4,500-scan drive need not be held at once).
 *
 * add() moves each scan by its pose (as pcl::transformPointCloud) and adds its points to
 * their voxels' sums; centroids() gives what voxelCentroid gives for all moved scans
 * concatenated in the order added: the same points, order and bits, for any thread count
 * (voxels are sharded by key over the threads, and each voxel's sum runs in input order).
 */
class VoxelCentroidMap {
public:
  /** voxel_size must be > 0 (throws std::invalid_argument). */
  explicit VoxelCentroidMap(double voxel_size, unsigned num_threads = 0);
  ~VoxelCentroidMap();
  /** Moves the map. */
  VoxelCentroidMap(VoxelCentroidMap&&) noexcept;
  /** Move-assigns the map. */
  VoxelCentroidMap&
  operator=(VoxelCentroidMap&&) noexcept;

  /** A scan moved by its pose and grouped by voxel (group()), ready to be added. */
  class Grouped {
  public:
    Grouped();
    ~Grouped();
    /** Moves the grouping. */
    Grouped(Grouped&&) noexcept;
    /** Move-assigns the grouping. */
    Grouped&
    operator=(Grouped&&) noexcept;

  private:
    friend class VoxelCentroidMap;
    struct Impl;
    std::unique_ptr<Impl> impl_;
  };

  /** Adds `cloud` moved by `pose` (p_world = pose * p). Non-finite points are skipped;
   *  throws std::invalid_argument for a point too far from the origin for the voxel. */
  void
  add(const pcl::PointCloud<pcl::PointXYZ>& cloud,
      const Eigen::Matrix4d& pose = Eigen::Matrix4d::Identity());

  /** The costly half of add(cloud, pose), on num_threads threads (0: all): moves the
   *  cloud and groups its points by voxel. It reads nothing of the map, so several scans
   *  can be grouped at once (one thread each) and then added in their order, with the
   *  same result as adding each as it comes. Throws as add() does. */
  Grouped
  group(const pcl::PointCloud<pcl::PointXYZ>& cloud,
        const Eigen::Matrix4d& pose,
        unsigned num_threads) const;
  /** Adds a grouped scan and leaves `scan` empty; an empty one adds nothing. Throws
   *  std::invalid_argument for a scan grouped by a map of another voxel size. */
  void
  add(Grouped&& scan);

  /** Occupied voxels. */
  std::size_t
  size() const;

  /** One centroid per occupied voxel, in key order (x, then y, then z). */
  pcl::PointCloud<pcl::PointXYZ>::Ptr
  centroids() const;

private:
  struct Shard;
  double voxel_size_;
  unsigned num_threads_;
  std::vector<Shard> shards_;
};

} // namespace filters
} // namespace pcl_parallel
