/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/filters/voxel_grid.h>
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/normal_estimation.h>
#include <pcl_parallel/slam/reducer.h>

#include <limits>

namespace pcl_parallel {
namespace slam {

namespace {

/** The reduced points' k-d tree (scanner frame): the tree pLUM would build
 *  (ParallelLUM::setSearchTree: default bucket size, ids the point indices). */
std::shared_ptr<const KdTreeIndex>
scanTree(const Cloud& reduced, unsigned num_threads)
{
  auto tree = std::make_shared<KdTreeIndex>();
  tree->build(reduced.empty() ? nullptr : reduced.front().data,
              reduced.size(),
              sizeof(PointT) / sizeof(float),
              nullptr,
              num_threads);
  return tree;
}

/** Normals from reduced, not raw, neighbours: on a spinning LiDAR the nearest raw points
 *  lie along one ring, a nearly linear neighbourhood (docs/design.md, "Normals once per
 *  scan"). pLUM's estimator, by tree position, back in point order. */
std::vector<Eigen::Vector3f>
reducedNormals(const KdTreeIndex& tree,
               std::size_t num_points,
               unsigned num_threads,
               const std::optional<Eigen::Vector3f>& plane_normal)
{
  std::vector<Eigen::Vector3f> normals(num_points, Eigen::Vector3f::Zero());
  if (tree.empty())
    return normals;
  const std::vector<Eigen::Vector3f> by_position =
      plane_normal ? estimateUnitNormals(tree, 10, num_threads, *plane_normal)
                   : estimateUnitNormals(tree, 10, num_threads);
  for (std::uint32_t pos = 0; pos < tree.size(); ++pos)
    normals[tree.id(pos)] = by_position[pos];
  return normals;
}

} // namespace

Reducer::Reducer(double voxel_size,
                 double source_voxel_size,
                 unsigned num_threads,
                 const std::optional<Eigen::Vector3f>& plane_normal)
    : voxel_size_(voxel_size)
    , source_voxel_size_(source_voxel_size)
    , num_threads_(num_threads)
    , plane_normal_(plane_normal)
{}

Reducer::Reducer(const Parameters& resolved)
    : Reducer(resolved.reduction.voxel_size,
              resolved.reduction.source_voxel_size,
              resolved.num_threads,
              resolved.planar ? std::optional<Eigen::Vector3f>(resolved.guess.up.cast<float>())
                              : std::nullopt)
{}

ReducedScan
Reducer::reduce(const Cloud& deskewed) const
{
  ReducedScan scan;
  scan.reduced = filters::voxelCentroid(deskewed, voxel_size_, num_threads_);
  return scan;
}

Cloud::Ptr
Reducer::source(const ReducedScan& scan) const
{
  return filters::voxelNearestToCentroid(*scan.reduced, source_voxel_size_, num_threads_);
}

void
Reducer::describe(ReducedScan& scan) const
{
  if (scan.tree)
    return;
  scan.tree = scanTree(*scan.reduced, num_threads_);
  scan.normals = reducedNormals(*scan.tree, scan.reduced->size(), num_threads_, plane_normal_);
}

MapCloud::Ptr
scannerFrameCloud(const ReducedScan& scan)
{
  const Cloud& reduced = *scan.reduced;
  MapCloud::Ptr out(new MapCloud);
  out->resize(reduced.size());
  const Eigen::Vector3f none =
      Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  for (std::size_t i = 0; i < reduced.size(); ++i) {
    MapPoint& p = (*out)[i];
    p.getVector3fMap() = reduced[i].getVector3fMap();
    p.getNormalVector3fMap() =
        scan.normals[i] == Eigen::Vector3f::Zero() ? none : scan.normals[i];
    p.curvature = 0.0f;
  }
  return out;
}

MapCloud::Ptr
withNormals(const ReducedScan& scan)
{
  const Cloud& reduced = *scan.reduced;
  MapCloud::Ptr out(new MapCloud);
  out->reserve(reduced.size());
  for (std::size_t i = 0; i < reduced.size(); ++i) {
    if (scan.normals[i] == Eigen::Vector3f::Zero())
      continue;
    MapPoint p;
    p.getVector3fMap() = reduced[i].getVector3fMap();
    p.getNormalVector3fMap() = scan.normals[i];
    p.curvature = 0.0f;
    out->push_back(p);
  }
  return out;
}

} // namespace slam
} // namespace pcl_parallel
