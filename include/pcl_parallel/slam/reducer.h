/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/parameters.h>
#include <pcl_parallel/slam/scan_record.h>
#include <pcl_parallel/slam/types.h>

#include <Eigen/Core>

#include <optional>

namespace pcl_parallel {
namespace slam {

/**
 * \brief Scan reduction (the paper's octree reduction, Sec. VI; KISS-ICP's voxelization):
 * one centroid per voxel is kept for the map, pLUM and loop closing; a coarser sample of
 * those, per voxel the point nearest its centroid, is what pICP registers.
 */
class Reducer {
public:
  /** A reducer at \a voxel_size (kept points) and \a source_voxel_size (registered sample) on
   *  \a num_threads threads; with \a plane_normal, of 2D scans in the plane normal to it
   *  (Parameters::planar), whose normals lie in that plane. */
  Reducer(double voxel_size,
          double source_voxel_size,
          unsigned num_threads,
          const std::optional<Eigen::Vector3f>& plane_normal = std::nullopt);

  /** The reducer of resolved parameters: their voxels and threads, of 2D scans in the plane
   *  normal to guess.up where they are planar. */
  explicit Reducer(const Parameters& resolved);

  /** The deskewed scan reduced at voxel_size; no tree or normals yet (describe). */
  ReducedScan
  reduce(const Cloud& deskewed) const;

  /** The points pICP registers: per source voxel the reduced point nearest its centroid,
   *  so they lie on the surfaces. */
  Cloud::Ptr
  source(const ReducedScan& scan) const;

  /** Builds the scan's one k-d tree and its normals (PCA of each reduced point's 10
   *  nearest reduced points, zero where degenerate; of 2D scans, within their plane),
   *  unless built. */
  void
  describe(ReducedScan& scan) const;

private:
  double voxel_size_;
  double source_voxel_size_;
  unsigned num_threads_;
  std::optional<Eigen::Vector3f> plane_normal_;
};

/** The reduced points with their normals, NaN where none (pICP then skips a pair there),
 *  in the scanner frame: the points the scan's tree holds. */
MapCloud::Ptr
scannerFrameCloud(const ReducedScan& scan);

/** The reduced points that have a normal, with it: what goes into the local map. */
MapCloud::Ptr
withNormals(const ReducedScan& scan);

} // namespace slam
} // namespace pcl_parallel
