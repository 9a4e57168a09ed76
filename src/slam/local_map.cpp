/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/normal_estimation.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/slam/local_map.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>

namespace pcl_parallel {
namespace slam {

LocalMap::LocalMap(double voxel_size,
                   double max_distance,
                   int max_points_per_voxel,
                   NormalsFromMap normals,
                   unsigned num_threads)
    : voxel_size_(voxel_size)
    , max_distance_(max_distance)
    , max_points_(static_cast<std::size_t>(std::max(1, max_points_per_voxel)))
    , normals_(normals)
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

namespace {

/** Fixed, so a voxel's shard never depends on the thread count. */
constexpr std::size_t kShards = 64;
constexpr std::uint8_t kNoShard = 0xff;
static_assert(kShards < kNoShard, "a shard index must differ from kNoShard");

} // namespace

template <typename ScanOf>
void
LocalMap::insert(const MapCloud& points, const ScanOf& scan_of)
{
  if (shards_.empty())
    shards_.resize(kShards);
  const std::int64_t n = static_cast<std::int64_t>(points.size());
  const unsigned threads = n > 5000 ? num_threads_ : 1;
  // Each point's voxel and shard (none: not finite, or beyond the int32 voxel keys).
  std::vector<Key> keys(points.size());
  std::vector<std::uint8_t> shard(points.size());
  parallelFor(
      points.size(),
      threads,
      evenGrain(points.size(), threads),
      [&](std::size_t first, std::size_t last) {
        for (std::size_t i = first; i < last; ++i) {
          const MapPoint& p = points[i];
          const bool valid = std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) &&
                             p.getVector3fMap().cwiseAbs().maxCoeff() < 2e9 * voxel_size_;
          keys[i] = valid ? key(p) : Key{};
          shard[i] = valid ? static_cast<std::uint8_t>(KeyHash()(keys[i]) % kShards) : kNoShard;
        }
      });
  // The points by shard, each shard's in input order (a counting sort).
  std::vector<std::uint32_t> begin(kShards + 2, 0), by_shard(points.size());
  for (const std::uint8_t s : shard)
    if (s != kNoShard)
      ++begin[s + 2];
  for (std::size_t s = 0; s <= kShards; ++s)
    begin[s + 1] += begin[s];
  for (std::int64_t i = 0; i < n; ++i)
    if (shard[i] != kNoShard)
      by_shard[begin[shard[i] + 1]++] = static_cast<std::uint32_t>(i);
  // Each shard fills its voxels as one pass over all points would; a new voxel is noted at
  // its first point, so that order_ gets the new voxels in input order.
  std::vector<Voxels::value_type*> created(points.size(), nullptr);
  parallelFor(kShards, threads, 1, [&](std::size_t s0, std::size_t s1) {
    for (std::size_t s = s0; s < s1; ++s) {
      for (std::uint32_t b = begin[s]; b < begin[s + 1]; ++b) {
        const std::uint32_t i = by_shard[b];
        auto [it, is_new] = shards_[s].try_emplace(keys[i]);
        if (is_new)
          created[i] = &*it;
        Voxel& voxel = it->second;
        if (voxel.points.size() < max_points_) {
          voxel.points.push_back(points[i]);
          voxel.scans.push_back(scan_of(i));
        }
      }
    }
  });
  for (Voxels::value_type* v : created)
    if (v)
      order_.push_back(v);
}

void
LocalMap::update(const MapCloud& points, const Eigen::Vector3d& origin, std::uint32_t scan)
{
  insert(points, [scan](std::size_t) { return scan; });
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
    parallelFor(far.size(),
                num_threads_,
                evenGrain(far.size(), num_threads_),
                [&](std::size_t first, std::size_t last) {
                  for (std::size_t v = first; v < last; ++v)
                    far[v] = out_of_reach(static_cast<std::int64_t>(v));
                });
  }
  std::size_t kept = 0;
  for (std::int64_t v = 0; v < voxels; ++v) {
    if (far.empty() ? out_of_reach(v) : far[v]) {
      const Key k = order_[v]->first; // a copy: the key dies with the element
      shards_[KeyHash()(k) % kShards].erase(k);
    }
    else
      order_[kept++] = order_[v];
  }
  order_.resize(kept);
  Fresh fresh;
  refresh(normals_.k > 0 ? &fresh : nullptr);
  if (!fresh.empty())
    estimateNormals(fresh);
}

void
LocalMap::estimateNormals(const Fresh& fresh)
{
  std::vector<float> xyz;
  for (const auto& [voxel, from] : fresh)
    for (std::size_t j = from; j < voxel->points.size(); ++j)
      xyz.insert(xyz.end(), voxel->points[j].data, voxel->points[j].data + 3);
  const Eigen::Vector3f up = Eigen::Vector3f::UnitZ();
  const std::vector<Eigen::Vector3f> normals =
      estimateUnitNormalsAt(*index(),
                            xyz.data(),
                            xyz.size() / 3,
                            3,
                            normals_.k,
                            num_threads_,
                            normals_.planar ? &up : nullptr);
  const Eigen::Vector3f none =
      Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  std::size_t i = 0;
  for (const auto& [voxel, from] : fresh)
    for (std::uint32_t j = from; j < voxel->points.size(); ++j, ++i) {
      const Eigen::Vector3f n = normals[i].isZero() ? none : normals[i]; // NaN: no plane
      voxel->points[j].getNormalVector3fMap() = n;
      (*cloud_)[voxel->cloud_at + j].getNormalVector3fMap() = n;
    }
}

void
LocalMap::transform(const Pose& correction)
{
  const Eigen::Matrix3f r = correction.topLeftCorner<3, 3>().cast<float>();
  const Eigen::Vector3f t = correction.topRightCorner<3, 1>().cast<float>();
  MapCloud points;
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
  insert(points, [&scans](std::size_t i) { return scans[i]; });
  refresh();
}

void
LocalMap::clear()
{
  shards_.clear();
  order_.clear();
  cloud_.reset();
  cloud_scans_.clear();
  base_index_.reset();
  index_.reset();
  renamed_.clear();
  unindexed_.clear();
  index_changes_ = 0;
}

bool
LocalMap::parallel(std::int64_t voxels) const
{
  return num_threads_ > 1 && voxels > 10000;
}

void
LocalMap::refresh(Fresh* fresh)
{
  const std::int64_t voxels = static_cast<std::int64_t>(order_.size());
  std::vector<std::size_t> first(order_.size() + 1, 0);
  for (std::int64_t v = 0; v < voxels; ++v) {
    Voxel& voxel = order_[v]->second;
    if (fresh && voxel.in_cloud < voxel.points.size())
      fresh->emplace_back(&voxel, voxel.in_cloud);
    voxel.in_cloud = static_cast<std::uint32_t>(voxel.points.size());
    voxel.cloud_at = static_cast<std::uint32_t>(first[v]);
    first[v + 1] = first[v] + voxel.points.size();
  }
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
    parallelFor(
        order_.size(),
        num_threads_,
        evenGrain(order_.size(), num_threads_),
        [&](std::size_t v0, std::size_t v1) {
          for (std::size_t v = v0; v < v1; ++v) {
            const Voxel& voxel = order_[v]->second;
            std::copy(voxel.points.begin(), voxel.points.end(), cloud_->begin() + first[v]);
            std::copy(voxel.scans.begin(), voxel.scans.end(), cloud_scans_.begin() + first[v]);
          }
        });
  }
  index_.reset();
  if (base_index_)
    trackIndex();
}

void
LocalMap::trackIndex()
{
  renamed_.assign(base_index_->size(), KdTreeIndex::kInvalid);
  unindexed_.clear();
  std::size_t kept = 0;
  for (const auto* v : order_) {
    const Voxel& voxel = v->second;
    for (std::uint32_t j = 0; j < voxel.in_cloud; ++j)
      if (j < voxel.indexed)
        renamed_[voxel.indexed_at + j] = voxel.cloud_at + j;
      else
        unindexed_.push_back(voxel.cloud_at + j);
    kept += voxel.indexed;
  }
  index_changes_ = unindexed_.size() + (base_index_->size() - kept);
}

std::shared_ptr<const KdTreeIndex>
LocalMap::index()
{
  if (index_)
    return index_;
  const MapCloud::ConstPtr cloud = this->cloud();
  constexpr std::size_t kStride = sizeof(MapPoint) / sizeof(float);
  if (!base_index_ ||
      static_cast<double>(index_changes_) > kIndexRebuildFraction * base_index_->size()) {
    auto built = std::make_shared<KdTreeIndex>();
    built->build(cloud->empty() ? nullptr : cloud->front().data,
                 cloud->size(),
                 kStride,
                 nullptr,
                 num_threads_);
    for (auto* v : order_) {
      v->second.indexed = v->second.in_cloud;
      v->second.indexed_at = v->second.cloud_at;
    }
    renamed_.clear();
    unindexed_.clear();
    index_changes_ = 0;
    return index_ = base_index_ = std::move(built);
  }
  // The last tree built, less the points cropped since, plus a tree over those added.
  std::vector<float> xyz(3 * unindexed_.size());
  for (std::size_t i = 0; i < unindexed_.size(); ++i)
    std::copy_n((*cloud)[unindexed_[i]].data, 3, &xyz[3 * i]);
  KdTreeIndex added;
  added.build(xyz.empty() ? nullptr : xyz.data(),
              unindexed_.size(),
              3,
              unindexed_.data(),
              num_threads_);
  return index_ = std::make_shared<const KdTreeIndex>(
             KdTreeIndex::merge(*base_index_, renamed_, added));
}

MapCloud::ConstPtr
LocalMap::cloud() const
{
  return cloud_ ? cloud_ : MapCloud::ConstPtr(new MapCloud);
}

} // namespace slam
} // namespace pcl_parallel
