/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/types.h>

#include <array>
#include <cstdint>
#include <memory>
#include <unordered_map>
#include <utility>
#include <vector>

namespace pcl_parallel {
class KdTreeIndex;
} // namespace pcl_parallel

namespace pcl_parallel {
namespace slam {

/** LocalMap's normals for the points an update() adds: estimated from the map. */
struct NormalsFromMap {
  unsigned k = 0;      ///< neighbours per normal (the point included); 0: the points' own
  bool planar = false; ///< within the x-y plane (2D scans: point-to-line)
};

/**
 * \brief The local map a scan is matched against: the recent scans' points in world
 * coordinates, thinned to at most `max_points_per_voxel` per voxel and cropped to
 * `max_distance` around the scanner (3DTK's metascan; KISS-ICP's voxel hash map, Vizzo
 * et al. 2023, Sec. III-D).
 *
 * A voxel keeps the first points that reach it, so the map is a deterministic function
 * of the scans added, in order. cloud() is the map as one point cloud for the
 * registration's k-d tree, refreshed after every update, so that the next scan is matched
 * against every scan kept.
 *
 * index() is a k-d tree over cloud(), kept current without a build over the whole map at
 * each refresh: the last tree built is merged with one over the points added since,
 * leaving out those cropped since (KdTreeIndex::merge), until the points added and
 * cropped exceed `kIndexRebuildFraction` of it (docs/design.md, "Local map").
 *
 * The points keep the normals they come with, or (NormalsFromMap) get them from the map
 * when they join it: from their nearest map points, the new scan's included. A sparse
 * scan (a 2D scanner's, a Livox's) has too few neighbours of its own for a normal.
 */
class LocalMap {
public:
  /** Share of the last built index's points added or cropped since, after which index()
   *  is built over the whole map again rather than merged. */
  static constexpr double kIndexRebuildFraction = 0.25;

  /** num_threads: for the per-scan crop and the refresh (0 = all cores); the map is the
   *  same for any. */
  LocalMap(double voxel_size,
           double max_distance,
           int max_points_per_voxel,
           NormalsFromMap normals = {},
           unsigned num_threads = 0);
  // Moves keep the voxels' nodes, and order_ points into them; a copy would not.
  /** Moves the map. */
  LocalMap(LocalMap&&) noexcept = default;
  /** Move-assigns the map. */
  LocalMap&
  operator=(LocalMap&&) noexcept = default;
  LocalMap(const LocalMap&) = delete;
  LocalMap&
  operator=(const LocalMap&) = delete;

  /** Adds points (world frame) of scan number `scan`, then drops the voxels farther than
   *  max_distance from `origin` (the scanner's position); with NormalsFromMap, the added
   *  points' normals are estimated. */
  void
  update(const MapCloud& points, const Eigen::Vector3d& origin, std::uint32_t scan = 0);

  /** Moves every point by a rigid correction (after loop closing moved the scans). */
  void
  transform(const Pose& correction);

  /** Removes every point. */
  void
  clear();

  /** True when the map holds no point. */
  bool
  empty() const
  {
    return order_.empty();
  }

  /** The map's points; the same object until the next update() or transform(). */
  MapCloud::ConstPtr
  cloud() const;

  /** A k-d tree over cloud() (ids: its indices), current with it; the same object until
   *  the next update() or transform(). Built or merged here, at the first call after one. */
  std::shared_ptr<const KdTreeIndex>
  index();

  /** Per point of cloud(): the scan it came from (update's `scan`). */
  const std::vector<std::uint32_t>&
  scans() const
  {
    return cloud_scans_;
  }

private:
  using Key = std::array<std::int32_t, 3>;
  struct KeyHash {
    std::size_t
    operator()(const Key& k) const
    {
      // The spatial hash of Teschner et al. 2003 (also KISS-ICP's).
      return static_cast<std::size_t>(static_cast<std::uint32_t>(k[0]) * 73856093u ^
                                      static_cast<std::uint32_t>(k[1]) * 19349669u ^
                                      static_cast<std::uint32_t>(k[2]) * 83492791u);
    }
  };
  Key
  key(const MapPoint& p) const;
  /** Adds each point (points[i] of scan scan_of(i)) to its voxel unless that is full; new
   *  voxels join order_ in the order of their first points, as one by one would. */
  template <typename ScanOf>
  void
  insert(const MapCloud& points, const ScanOf& scan_of);
  /** renamed_, unindexed_ and index_changes_ for cloud_ as refreshed. */
  void
  trackIndex();
  /** Whether a pass over this many voxels runs in parallel. */
  bool
  parallel(std::int64_t voxels) const;

  double voxel_size_;
  double max_distance_;
  std::size_t max_points_;
  NormalsFromMap normals_;
  unsigned num_threads_;
  struct Voxel {
    std::vector<MapPoint> points;
    std::vector<std::uint32_t> scans; ///< per point: the scan it came from
    std::uint32_t in_cloud = 0;       ///< leading points in cloud_ ...
    std::uint32_t cloud_at = 0;       ///< ... from this index of it on
    std::uint32_t indexed = 0;        ///< leading points in base_index_ ...
    std::uint32_t indexed_at = 0;     ///< ... where cloud_ had them at its build
  };
  /** A voxel and the first of its points added since the last refresh. */
  using Fresh = std::vector<std::pair<Voxel*, std::uint32_t>>;
  /** cloud_ from the voxels; with `fresh`, the voxels given points since the last one. */
  void
  refresh(Fresh* fresh = nullptr);
  /** Normals from the map (normals_) for each voxel's points from its slot `from` on. */
  void
  estimateNormals(const Fresh& fresh);
  using Voxels = std::unordered_map<Key, Voxel, KeyHash>;
  /** The voxels by key hash modulo their number, fixed: a scan's points go into all
   *  shards at once, each shard's in input order (docs/design.md, "Serial work per scan"). */
  std::vector<Voxels> shards_;
  /** Voxels in creation order, so cloud() is independent of hashing; pointers to the
   *  elements (a rehash keeps them valid), so the per-scan crop and refresh walk the
   *  voxels without a hash lookup each. */
  std::vector<Voxels::value_type*> order_;
  MapCloud::Ptr cloud_;
  std::vector<std::uint32_t> cloud_scans_; ///< per point of cloud_
  /** The last index built over a whole cloud_ (ids: that cloud's indices), and index()'s
   *  answer for cloud_ (null until asked). */
  std::shared_ptr<const KdTreeIndex> base_index_, index_;
  /** Since base_index_, at the last refresh: each of its ids' index in cloud_ now
   *  (kInvalid: cropped), and the indices of cloud_ it lacks. */
  std::vector<std::uint32_t> renamed_, unindexed_;
  std::size_t index_changes_ = 0; ///< unindexed_ and base_index_'s points cropped since
};

} // namespace slam
} // namespace pcl_parallel
