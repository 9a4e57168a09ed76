/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/filters/voxel_grid.h>
#include <pcl_parallel/parallel.h>

#include <pcl/common/transforms.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

namespace pcl_parallel {
namespace filters {

namespace {

/** A point's voxel key packed into 64 bits (x, then y, then z, each offset by its minimum,
 *  so integer order is the lexicographic order of the keys) and its index. */
struct Keyed {
  std::uint64_t key;
  std::uint32_t index;
};

/** Stable LSD radix sort by key, 8 bits a pass over the `bits` low bits: O(n), and equal
 *  keys keep their input (index) order, which fixes each centroid's summation order. */
void
radixSort(std::vector<Keyed>& a, int bits)
{
  std::vector<Keyed> b(a.size());
  for (int shift = 0; shift < bits; shift += 8) {
    std::size_t count[257] = {0};
    for (const Keyed& k : a)
      ++count[((k.key >> shift) & 0xff) + 1];
    for (int d = 0; d < 256; ++d)
      count[d + 1] += count[d];
    for (const Keyed& k : a)
      b[count[(k.key >> shift) & 0xff]++] = k;
    a.swap(b);
  }
}

int
bitWidth(std::uint64_t v)
{
  int w = 0;
  for (; v; v >>= 1)
    ++w;
  return w;
}

} // namespace

pcl::PointCloud<pcl::PointXYZ>::Ptr
voxelCentroid(const pcl::PointCloud<pcl::PointXYZ>& cloud,
              double voxel_size,
              unsigned num_threads)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr out(new pcl::PointCloud<pcl::PointXYZ>);
  if (cloud.size() > std::numeric_limits<std::uint32_t>::max())
    throw std::invalid_argument("voxelCentroid: more than 2^32 points");
  const std::int64_t n = static_cast<std::int64_t>(cloud.size());
  auto finite = [&](std::int64_t i) {
    return std::isfinite(cloud[i].x) && std::isfinite(cloud[i].y) && std::isfinite(cloud[i].z);
  };
  if (!(voxel_size > 0.0)) {
    for (std::int64_t i = 0; i < n; ++i)
      if (finite(i))
        out->push_back(cloud[i]);
    return out;
  }
  // Voxel keys: floor(p / voxel_size) per axis; non-finite points get none (INT64_MIN).
  const double inv = 1.0 / voxel_size;
  constexpr double limit = 2147483647.0;
  constexpr std::int64_t none = std::numeric_limits<std::int64_t>::min();
  std::vector<std::int64_t> coords(3 * cloud.size(), none);
  bool too_far = false;
  const unsigned threads = resolveNumberOfThreads(num_threads);
#pragma omp parallel for num_threads(threads) schedule(static)                                 \
    reduction(||                                                                               \
              : too_far) if (threads > 1 && n > 10000)
  for (std::int64_t i = 0; i < n; ++i) {
    if (!finite(i))
      continue;
    const double c[3] = {std::floor(cloud[i].x * inv),
                         std::floor(cloud[i].y * inv),
                         std::floor(cloud[i].z * inv)};
    if (std::abs(c[0]) >= limit || std::abs(c[1]) >= limit || std::abs(c[2]) >= limit) {
      too_far = true;
      continue;
    }
    for (int a = 0; a < 3; ++a)
      coords[3 * i + a] = static_cast<std::int64_t>(c[a]);
  }
  if (too_far)
    throw std::invalid_argument("voxelCentroid: a point lies more than 2^31 voxels of " +
                                std::to_string(voxel_size) + " from the origin");
  std::int64_t lo[3], hi[3];
  std::fill(lo, lo + 3, std::numeric_limits<std::int64_t>::max());
  std::fill(hi, hi + 3, none);
  for (std::int64_t i = 0; i < n; ++i)
    if (coords[3 * i] != none)
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], coords[3 * i + a]);
        hi[a] = std::max(hi[a], coords[3 * i + a]);
      }
  // Each axis gets the bits its extent needs; 3 x 32 bits always fit in 96, and 64 hold
  // any extent below 2^21 voxels an axis (e.g. 200 km at 10 cm), so the wide case sorts
  // by a second key word only when it must.
  int width[3];
  for (int a = 0; a < 3; ++a)
    width[a] = hi[a] >= lo[a] ? bitWidth(static_cast<std::uint64_t>(hi[a] - lo[a])) : 0;
  const int bits = width[0] + width[1] + width[2];
  std::vector<Keyed> keyed;
  keyed.reserve(cloud.size());
  if (bits <= 64) {
    for (std::int64_t i = 0; i < n; ++i)
      if (coords[3 * i] != none) {
        const std::uint64_t x = static_cast<std::uint64_t>(coords[3 * i] - lo[0]);
        const std::uint64_t y = static_cast<std::uint64_t>(coords[3 * i + 1] - lo[1]);
        const std::uint64_t z = static_cast<std::uint64_t>(coords[3 * i + 2] - lo[2]);
        keyed.push_back({(x << (width[1] + width[2])) | (y << width[2]) | z,
                         static_cast<std::uint32_t>(i)});
      }
    radixSort(keyed, bits);
  }
  else { // z first, then (x, y): two stable passes give the (x, y, z) order
    for (std::int64_t i = 0; i < n; ++i)
      if (coords[3 * i] != none)
        keyed.push_back({static_cast<std::uint64_t>(coords[3 * i + 2] - lo[2]),
                         static_cast<std::uint32_t>(i)});
    radixSort(keyed, width[2]);
    for (Keyed& k : keyed)
      k.key = (static_cast<std::uint64_t>(coords[3 * k.index] - lo[0]) << 32) |
              static_cast<std::uint64_t>(coords[3 * k.index + 1] - lo[1]);
    radixSort(keyed, 64);
  }

  // One centroid per run of equal voxels, summed in double in input order.
  auto same = [&](const Keyed& a, const Keyed& b) {
    return coords[3 * a.index] == coords[3 * b.index] &&
           coords[3 * a.index + 1] == coords[3 * b.index + 1] &&
           coords[3 * a.index + 2] == coords[3 * b.index + 2];
  };
  for (std::size_t b = 0; b < keyed.size();) {
    std::size_t e = b;
    double sx = 0.0, sy = 0.0, sz = 0.0;
    for (; e < keyed.size() && same(keyed[e], keyed[b]); ++e) {
      const auto& p = cloud[keyed[e].index];
      sx += p.x, sy += p.y, sz += p.z;
    }
    const double count = static_cast<double>(e - b);
    out->push_back(pcl::PointXYZ(static_cast<float>(sx / count),
                                 static_cast<float>(sy / count),
                                 static_cast<float>(sz / count)));
    b = e;
  }
  return out;
}

// ---------------------------------------------------------------------------------------
// VoxelCentroidMap

namespace {

using VoxelKey = std::array<std::int32_t, 3>;

struct VoxelKeyHash {
  std::size_t
  operator()(const VoxelKey& k) const
  {
    // The spatial hash of Teschner et al. 2003 (also KISS-ICP's voxel map).
    return static_cast<std::size_t>(static_cast<std::uint32_t>(k[0]) * 73856093u ^
                                    static_cast<std::uint32_t>(k[1]) * 19349669u ^
                                    static_cast<std::uint32_t>(k[2]) * 83492791u);
  }
};

/** Fixed, so a voxel's shard (and with it nothing but the work split) is independent of
 *  the thread count. */
constexpr std::size_t kShards = 64;

} // namespace

struct VoxelCentroidMap::Shard {
  struct Sum {
    double x = 0.0, y = 0.0, z = 0.0;
    std::uint64_t count = 0;
  };
  std::unordered_map<VoxelKey, Sum, VoxelKeyHash> voxels;
};

VoxelCentroidMap::VoxelCentroidMap(double voxel_size, unsigned num_threads)
    : voxel_size_(voxel_size)
    , num_threads_(num_threads)
    , shards_(kShards)
{
  if (!(voxel_size > 0.0) || !std::isfinite(voxel_size))
    throw std::invalid_argument("VoxelCentroidMap: the voxel size must be positive");
}

VoxelCentroidMap::~VoxelCentroidMap() = default;
VoxelCentroidMap::VoxelCentroidMap(VoxelCentroidMap&&) noexcept = default;
VoxelCentroidMap&
VoxelCentroidMap::operator=(VoxelCentroidMap&&) noexcept = default;

void
VoxelCentroidMap::add(const pcl::PointCloud<pcl::PointXYZ>& cloud, const Eigen::Matrix4d& pose)
{
  pcl::PointCloud<pcl::PointXYZ> moved;
  pcl::transformPointCloud(cloud, moved, pose);
  const std::int64_t n = static_cast<std::int64_t>(moved.size());
  const double inv = 1.0 / voxel_size_;
  constexpr double limit = 2147483647.0;
  std::vector<VoxelKey> keys(moved.size());
  std::vector<std::uint8_t> shard(moved.size(), kShards); // kShards: no voxel
  bool too_far = false;
  const unsigned threads = resolveNumberOfThreads(num_threads_);
  VoxelKeyHash hash;
#pragma omp parallel for num_threads(threads) schedule(static)                                 \
    reduction(||                                                                               \
              : too_far) if (threads > 1 && n > 10000)
  for (std::int64_t i = 0; i < n; ++i) {
    const auto& p = moved[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      continue;
    const double c[3] = {std::floor(p.x * inv), std::floor(p.y * inv), std::floor(p.z * inv)};
    if (std::abs(c[0]) >= limit || std::abs(c[1]) >= limit || std::abs(c[2]) >= limit) {
      too_far = true;
      continue;
    }
    keys[i] = {static_cast<std::int32_t>(c[0]),
               static_cast<std::int32_t>(c[1]),
               static_cast<std::int32_t>(c[2])};
    shard[i] = static_cast<std::uint8_t>(hash(keys[i]) % kShards);
  }
  if (too_far)
    throw std::invalid_argument("VoxelCentroidMap: a point lies more than 2^31 voxels of " +
                                std::to_string(voxel_size_) + " from the origin");
    // Each shard walks the points in order: a voxel's sum runs in input order.
#pragma omp parallel for num_threads(threads) schedule(dynamic) if (threads > 1 && n > 10000)
  for (std::int64_t s = 0; s < static_cast<std::int64_t>(kShards); ++s) {
    auto& voxels = shards_[s].voxels;
    for (std::int64_t i = 0; i < n; ++i)
      if (shard[i] == s) {
        auto& v = voxels[keys[i]];
        v.x += moved[i].x, v.y += moved[i].y, v.z += moved[i].z;
        ++v.count;
      }
  }
}

std::size_t
VoxelCentroidMap::size() const
{
  std::size_t n = 0;
  for (const auto& s : shards_)
    n += s.voxels.size();
  return n;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr
VoxelCentroidMap::centroids() const
{
  std::vector<std::pair<VoxelKey, const Shard::Sum*>> all;
  all.reserve(size());
  for (const auto& s : shards_)
    for (const auto& [key, sum] : s.voxels)
      all.emplace_back(key, &sum);
  std::sort(
      all.begin(), all.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  pcl::PointCloud<pcl::PointXYZ>::Ptr out(new pcl::PointCloud<pcl::PointXYZ>);
  out->reserve(all.size());
  for (const auto& [key, v] : all) {
    const double count = static_cast<double>(v->count);
    out->push_back(pcl::PointXYZ(static_cast<float>(v->x / count),
                                 static_cast<float>(v->y / count),
                                 static_cast<float>(v->z / count)));
  }
  return out;
}

} // namespace filters
} // namespace pcl_parallel
