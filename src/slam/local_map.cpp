/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/slam/local_map.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pcl_parallel {
namespace slam {

LocalMap::LocalMap(double voxel_size,
                   double max_distance,
                   int max_points_per_voxel,
                   double refresh_fraction)
    : voxel_size_(voxel_size)
    , max_distance_(max_distance)
    , max_points_(static_cast<std::size_t>(std::max(1, max_points_per_voxel)))
    , refresh_fraction_(std::max(0.0, refresh_fraction))
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
  // Crop: a voxel goes when its first point is out of reach (KISS-ICP's rule).
  const double max2 = max_distance_ * max_distance_;
  std::size_t kept = 0;
  for (auto* voxel : order_) {
    if ((voxel->second.points.front().getVector3fMap().cast<double>() - origin).squaredNorm() >
        max2)
      voxels_.erase(Key(voxel->first)); // a copy: the key dies with the element
    else
      order_[kept++] = voxel;
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

void
LocalMap::refresh()
{
  std::size_t n = 0;
  for (const auto* voxel : order_)
    n += voxel->second.points.size();
  cloud_.reset(new MapCloud);
  cloud_->reserve(n);
  cloud_scans_.clear();
  cloud_scans_.reserve(n);
  for (const auto* voxel : order_) {
    for (const auto& p : voxel->second.points)
      cloud_->push_back(p);
    cloud_scans_.insert(
        cloud_scans_.end(), voxel->second.scans.begin(), voxel->second.scans.end());
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
