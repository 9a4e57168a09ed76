/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/slam/local_map.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pcl_parallel {
namespace slam {

LocalMap::LocalMap(double voxel_size,
                   double max_distance,
                   int max_points_per_voxel,
                   double refresh_fraction,
                   unsigned num_threads)
    : voxel_size_(voxel_size)
    , max_distance_(max_distance)
    , max_points_(static_cast<std::size_t>(std::max(1, max_points_per_voxel)))
    , refresh_fraction_(std::max(0.0, refresh_fraction))
    , num_threads_(resolveNumberOfThreads(num_threads))
{
  if (!(voxel_size > 0.0) || !(max_distance > 0.0))
    throw std::invalid_argument("LocalMap: voxel size and distance must be positive");
}

LocalMap::Key
LocalMap::key(const MapPoint& p) const
{
  return {static_cast<std::int32_t>(std::floor(p.x / voxel_size_)),
          static_cast<std::int32_t>(std::floor(p.y / voxel_size_)),
          static_cast<std::int32_t>(std::floor(p.z / voxel_size_))};
}

void
LocalMap::insert(const MapPoint& p, std::uint32_t scan)
{
  const Key k = key(p);
  auto [it, created] = voxels_.try_emplace(k);
  if (created)
    order_.push_back(&*it);
  if (it->second.points.size() < max_points_) {
    it->second.points.push_back(p);
    it->second.scans.push_back(scan);
    ++added_;
  }
}

void
LocalMap::update(const MapCloud& points, const Eigen::Vector3d& origin, std::uint32_t scan)
{
  for (const auto& p : points)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) &&
        p.getVector3fMap().cwiseAbs().maxCoeff() < 2e9 * voxel_size_) // int32 voxel keys
      insert(p, scan);
  // Crop: a voxel goes when its first point is out of reach (KISS-ICP's rule). On a large
  // map every voxel is tested in parallel first; the few erasures follow in order.
  const double max2 = max_distance_ * max_distance_;
  const std::int64_t voxels = static_cast<std::int64_t>(order_.size());
  const auto out_of_reach = [&](std::int64_t v) {
    return (order_[v]->second.points.front().getVector3fMap().cast<double>() - origin)
               .squaredNorm() > max2;
  };
  std::vector<char> far;
  if (parallel(voxels)) {
    far.resize(order_.size());
#pragma omp parallel for num_threads(num_threads_) schedule(static)
    for (std::int64_t v = 0; v < voxels; ++v)
      far[v] = out_of_reach(v);
  }
  std::size_t kept = 0;
  for (std::int64_t v = 0; v < voxels; ++v) {
    if (far.empty() ? out_of_reach(v) : far[v])
      voxels_.erase(Key(order_[v]->first)); // a copy: the key dies with the element
    else
      order_[kept++] = order_[v];
  }
  order_.resize(kept);
  if (!cloud_ || static_cast<double>(added_) > refresh_fraction_ * cloud_->size())
    refresh();
}

void
LocalMap::transform(const Pose& correction)
{
  const Eigen::Matrix3f r = correction.topLeftCorner<3, 3>().cast<float>();
  const Eigen::Vector3f t = correction.topRightCorner<3, 1>().cast<float>();
  std::vector<MapPoint> points;
  std::vector<std::uint32_t> scans;
  for (const auto* voxel : order_)
    for (std::size_t i = 0; i < voxel->second.points.size(); ++i) {
      const MapPoint& p = voxel->second.points[i];
      MapPoint q = p;
      q.getVector3fMap() = r * p.getVector3fMap() + t;
      q.getNormalVector3fMap() = r * p.getNormalVector3fMap();
      points.push_back(q);
      scans.push_back(voxel->second.scans[i]);
    }
  clear();
  for (std::size_t i = 0; i < points.size(); ++i)
    insert(points[i], scans[i]);
  refresh();
}

void
LocalMap::clear()
{
  voxels_.clear();
  order_.clear();
  cloud_.reset();
  cloud_scans_.clear();
  added_ = 0;
}

bool
LocalMap::parallel(std::int64_t voxels) const
{
  return num_threads_ > 1 && voxels > 10000;
}

void
LocalMap::refresh()
{
  const std::int64_t voxels = static_cast<std::int64_t>(order_.size());
  std::vector<std::size_t> first(order_.size() + 1, 0);
  for (std::int64_t v = 0; v < voxels; ++v)
    first[v + 1] = first[v] + order_[v]->second.points.size();
  cloud_.reset(new MapCloud);
  if (!parallel(voxels)) {
    cloud_->reserve(first.back());
    cloud_scans_.clear();
    cloud_scans_.reserve(first.back());
    for (const auto* voxel : order_) {
      cloud_->insert(cloud_->end(), voxel->second.points.begin(), voxel->second.points.end());
      cloud_scans_.insert(
          cloud_scans_.end(), voxel->second.scans.begin(), voxel->second.scans.end());
    }
  }
  else { // each voxel's points to their place in voxel order, in parallel
    cloud_->resize(first.back());
    cloud_scans_.resize(first.back());
#pragma omp parallel for num_threads(num_threads_) schedule(static)
    for (std::int64_t v = 0; v < voxels; ++v) {
      const Voxel& voxel = order_[v]->second;
      std::copy(voxel.points.begin(), voxel.points.end(), cloud_->begin() + first[v]);
      std::copy(voxel.scans.begin(), voxel.scans.end(), cloud_scans_.begin() + first[v]);
    }
  }
  added_ = 0;
}

MapCloud::ConstPtr
LocalMap::cloud() const
{
  return cloud_ ? cloud_ : MapCloud::ConstPtr(new MapCloud);
}

} // namespace slam
} // namespace pcl_parallel
