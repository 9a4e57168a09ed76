/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "../uninitialized.h"

#include <pcl_parallel/filters/voxel_grid.h>
#include <pcl_parallel/parallel.h>

#include <pcl/common/transforms.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace pcl_parallel {
namespace filters {

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using VoxelKey = std::array<std::int32_t, 3>;

bool
sameKey(const VoxelKey& a, const VoxelKey& b)
{
  return a[0] == b[0] && a[1] == b[1] && a[2] == b[2];
}

bool
keyLess(const VoxelKey& a, const VoxelKey& b)
{
  return a[0] != b[0] ? a[0] < b[0] : a[1] != b[1] ? a[1] < b[1] : a[2] < b[2];
}

/** A point's voxel key packed into 64 bits (x, then y, then z, each offset by its minimum,
 *  so integer order is the lexicographic order of the keys) and its index. */
struct Keyed {
  std::uint64_t key;
  std::uint32_t index;
};

/** Points below this go through the grouping on one thread: the parallel passes' set-up
 *  costs more than they save on a small cloud. */
constexpr std::int64_t kParallelPoints = 20000;

/** Contiguous blocks of [0, n), one per thread: each parallel pass below handles its
 *  block's items in order, so the passes are stable and their output is the same for any
 *  block count. */
struct Blocks {
  std::int64_t n;
  int count;
  std::int64_t
  begin(int b) const
  {
    return n * b / count;
  }
};

/** fn(t) for each block t, one thread a block (parallelFor runs one block inline). */
template <typename Fn>
void
forEachBlock(int count, const Fn& fn)
{
  parallelFor(static_cast<std::size_t>(count),
              static_cast<unsigned>(count),
              1,
              [&](std::size_t first, std::size_t last) {
                for (std::size_t t = first; t < last; ++t)
                  fn(static_cast<int>(t));
              });
}

/** Stable LSD radix sort by key, 8 bits a pass over the `bits` low bits: O(n), and equal
 *  keys keep their input (index) order, which fixes each centroid's summation order. Each
 *  pass counts digits per block, places every (digit, block) run after all smaller digits
 *  and the earlier blocks' same digit, and scatters the blocks in parallel: a stable sort's
 *  output is unique, so it is the same for any thread count. */
void
radixSort(detail::UninitializedVector<Keyed>& a, int bits, unsigned threads)
{
  const Blocks blocks{
      static_cast<std::int64_t>(a.size()),
      static_cast<std::int64_t>(a.size()) >= kParallelPoints ? static_cast<int>(threads) : 1};
  detail::UninitializedVector<Keyed> b(a.size()); // each pass writes it whole
  std::vector<std::array<std::size_t, 256>> count(static_cast<std::size_t>(blocks.count));
  for (int shift = 0; shift < bits; shift += 8) {
    const auto histogram = [&](int t) {
      auto& c = count[t];
      c.fill(0);
      for (std::int64_t i = blocks.begin(t), end = blocks.begin(t + 1); i < end; ++i)
        ++c[(a[i].key >> shift) & 0xff];
    };
    const auto scatter = [&](int t) {
      auto& c = count[t];
      for (std::int64_t i = blocks.begin(t), end = blocks.begin(t + 1); i < end; ++i)
        b[c[(a[i].key >> shift) & 0xff]++] = a[i];
    };
    forEachBlock(blocks.count, histogram);
    std::size_t at = 0; // exclusive prefix, digit-major then block
    for (int d = 0; d < 256; ++d)
      for (int t = 0; t < blocks.count; ++t)
        at += std::exchange(count[t][d], at);
    forEachBlock(blocks.count, scatter);
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

/** The finite points of a cloud grouped by voxel: `order` lists point indices by voxel key
 *  (x, then y, then z) and, within a voxel, in input order; voxel v holds
 *  order[runs[v] .. runs[v + 1]) and has key keys[order[runs[v]]]. Every pass runs in
 *  parallel on a large cloud; the grouping is the same for any thread count. */
struct VoxelRuns {
  detail::UninitializedVector<VoxelKey> keys; ///< per point; unset where not finite
  detail::UninitializedVector<std::uint32_t> order;
  std::vector<std::uint32_t> runs;
};

/** Per point, its integer voxel coordinates (g.keys, where `valid`), and over all points
 *  the coordinates' bounds and each block's first slot among the finite points (back():
 *  their count). Throws where a point lies beyond int32 voxels. */
struct KeyRange {
  std::int64_t lo[3], hi[3];
  std::vector<std::size_t> first;
};

KeyRange
voxelKeys(const Cloud& cloud,
          double voxel_size,
          const Blocks& blocks,
          VoxelRuns& g,
          detail::UninitializedVector<char>& valid,
          const char* who)
{
  const double inv = 1.0 / voxel_size;
  constexpr double limit = 2147483647.0;
  // Per block: its keys, their exact integer bounds and its count of finite points.
  struct Bounds {
    std::int64_t lo[3], hi[3];
    std::size_t finite = 0;
    bool too_far = false;
  };
  std::vector<Bounds> bounds(static_cast<std::size_t>(blocks.count));
  forEachBlock(blocks.count, [&](int t) {
    Bounds b; // in registers: the char stores to `valid` may alias anything in memory
    std::fill(b.lo, b.lo + 3, std::numeric_limits<std::int64_t>::max());
    std::fill(b.hi, b.hi + 3, std::numeric_limits<std::int64_t>::min());
    for (std::int64_t i = blocks.begin(t), end = blocks.begin(t + 1); i < end; ++i) {
      const auto& p = cloud[i];
      valid[i] = 0;
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
        continue;
      const double c[3] = {std::floor(p.x * inv), std::floor(p.y * inv), std::floor(p.z * inv)};
      if (std::abs(c[0]) >= limit || std::abs(c[1]) >= limit || std::abs(c[2]) >= limit) {
        b.too_far = true;
        continue;
      }
      for (int a = 0; a < 3; ++a) {
        const auto k = static_cast<std::int32_t>(c[a]);
        g.keys[i][a] = k;
        b.lo[a] = std::min<std::int64_t>(b.lo[a], k);
        b.hi[a] = std::max<std::int64_t>(b.hi[a], k);
      }
      valid[i] = 1;
      ++b.finite;
    }
    bounds[t] = b;
  });
  KeyRange r;
  std::fill(r.lo, r.lo + 3, std::numeric_limits<std::int64_t>::max());
  std::fill(r.hi, r.hi + 3, std::numeric_limits<std::int64_t>::min());
  r.first.assign(bounds.size() + 1, 0);
  for (std::size_t t = 0; t < bounds.size(); ++t) {
    if (bounds[t].too_far)
      throw std::invalid_argument(std::string(who) +
                                  ": a point lies more than 2^31 voxels of " +
                                  std::to_string(voxel_size) + " from the origin");
    for (int a = 0; a < 3; ++a)
      r.lo[a] = std::min(r.lo[a], bounds[t].lo[a]),
      r.hi[a] = std::max(r.hi[a], bounds[t].hi[a]);
    r.first[t + 1] = r.first[t] + bounds[t].finite;
  }
  return r;
}

/** The finite points as (key, index), sorted by voxel and, within one, by index. `bits`
 *  (out): the key's width; above 64 the keys hold (x, y) alone and z is compared apart. */
detail::UninitializedVector<Keyed>
sortedByVoxel(const VoxelRuns& g,
              const KeyRange& r,
              const Blocks& blocks,
              const detail::UninitializedVector<char>& valid,
              int& bits)
{
  auto offset = [&](std::uint32_t i, int a) {
    return static_cast<std::uint64_t>(g.keys[i][a] - r.lo[a]);
  };
  // Each axis gets the bits its extent needs: 64 hold any extent below 2^21 voxels an
  // axis (200 km at 10 cm); wider clouds sort twice, by z and then by (x, y).
  int width[3];
  for (int a = 0; a < 3; ++a)
    width[a] = r.hi[a] >= r.lo[a] ? bitWidth(static_cast<std::uint64_t>(r.hi[a] - r.lo[a])) : 0;
  bits = width[0] + width[1] + width[2];
  // (A shift by 64 would be undefined; x's width is 0 then, so x adds nothing.)
  const int shift_x = width[1] + width[2];
  detail::UninitializedVector<Keyed> keyed(r.first.back());
  forEachBlock(blocks.count, [&](int t) {
    std::size_t j = r.first[t];
    for (std::int64_t i = blocks.begin(t), end = blocks.begin(t + 1); i < end; ++i)
      if (valid[i]) {
        const auto k = static_cast<std::uint32_t>(i);
        const std::uint64_t x = shift_x < 64 ? offset(k, 0) << shift_x : 0;
        keyed[j++] = {bits <= 64 ? x | (offset(k, 1) << width[2]) | offset(k, 2) : offset(k, 2),
                      k};
      }
  });
  radixSort(keyed, bits <= 64 ? bits : width[2], static_cast<unsigned>(blocks.count));
  if (bits > 64) {
    const auto threads = static_cast<unsigned>(blocks.count);
    parallelFor(keyed.size(),
                threads,
                evenGrain(keyed.size(), threads),
                [&](std::size_t first, std::size_t last) {
                  for (std::size_t j = first; j < last; ++j)
                    keyed[j].key =
                        (offset(keyed[j].index, 0) << 32) | offset(keyed[j].index, 1);
                });
    radixSort(keyed, 64, static_cast<unsigned>(blocks.count));
  }
  return keyed;
}

/** g.order and g.runs from the sorted keys: a voxel starts where the key changes; block by
 *  block, then gathered in order. */
void
collectRuns(const detail::UninitializedVector<Keyed>& keyed, int bits, int blocks, VoxelRuns& g)
{
  const auto starts = [&](std::int64_t j) {
    return j == 0 || keyed[j].key != keyed[j - 1].key ||
           (bits > 64 && g.keys[keyed[j].index][2] != g.keys[keyed[j - 1].index][2]);
  };
  const Blocks sorted{static_cast<std::int64_t>(keyed.size()), blocks};
  std::vector<std::vector<std::uint32_t>> runs(static_cast<std::size_t>(sorted.count));
  g.order.resize(keyed.size());
  forEachBlock(sorted.count, [&](int t) {
    for (std::int64_t j = sorted.begin(t), end = sorted.begin(t + 1); j < end; ++j) {
      if (starts(j))
        runs[t].push_back(static_cast<std::uint32_t>(j));
      g.order[j] = keyed[j].index;
    }
  });
  if (sorted.count == 1)
    g.runs.swap(runs[0]);
  else
    for (const auto& r : runs)
      g.runs.insert(g.runs.end(), r.begin(), r.end());
  g.runs.push_back(static_cast<std::uint32_t>(keyed.size()));
}

VoxelRuns
groupByVoxel(const Cloud& cloud, double voxel_size, unsigned num_threads, const char* who)
{
  if (cloud.size() >= std::numeric_limits<std::uint32_t>::max())
    throw std::invalid_argument(std::string(who) + ": 2^32 points or more");
  const std::int64_t n = static_cast<std::int64_t>(cloud.size());
  const unsigned threads = resolveNumberOfThreads(num_threads);
  const Blocks blocks{n, threads > 1 && n >= kParallelPoints ? static_cast<int>(threads) : 1};
  VoxelRuns g;
  // Per-point buffers are written in the parallel passes, not zeroed here (serially).
  g.keys.resize(cloud.size());
  detail::UninitializedVector<char> valid(cloud.size());
  const KeyRange range = voxelKeys(cloud, voxel_size, blocks, g, valid, who);
  int bits = 0;
  const detail::UninitializedVector<Keyed> keyed = sortedByVoxel(g, range, blocks, valid, bits);
  collectRuns(keyed, bits, blocks.count, g);
  return g;
}

/** The indices of the cloud's finite points, in input order. */
std::vector<std::uint32_t>
finitePoints(const Cloud& cloud)
{
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (std::isfinite(cloud[i].x) && std::isfinite(cloud[i].y) && std::isfinite(cloud[i].z))
      out.push_back(static_cast<std::uint32_t>(i));
  return out;
}

/** One value per voxel into `out` (a cloud, or indices), pick(cloud, first, last) of the
 *  voxel's points (cloud[*first] .. cloud[*(last - 1)], in input order), for every voxel
 *  in parallel: in key order and the same for any thread count. voxel_size > 0. */
template <typename Out, typename Pick>
void
pickPerVoxel(const Cloud& cloud,
             double voxel_size,
             unsigned num_threads,
             const char* who,
             Out& out,
             Pick pick)
{
  const VoxelRuns g = groupByVoxel(cloud, voxel_size, num_threads, who);
  const std::int64_t voxels = static_cast<std::int64_t>(g.runs.size()) - 1;
  out.resize(static_cast<std::size_t>(voxels));
  const unsigned threads = resolveNumberOfThreads(num_threads);
  const unsigned used = voxels > 5000 ? threads : 1;
  parallelFor(
      out.size(), used, evenGrain(out.size(), used), [&](std::size_t first, std::size_t last) {
        for (std::size_t v = first; v < last; ++v)
          out[v] = pick(cloud, g.order.data() + g.runs[v], g.order.data() + g.runs[v + 1]);
      });
}

/** A voxel's point: pick(cloud, first, last) of its points. */
using PickPoint = pcl::PointXYZ (*)(const Cloud& cloud,
                                    const std::uint32_t* first,
                                    const std::uint32_t* last);

/** One point per voxel (pickPerVoxel); voxel_size <= 0 (or NaN): the finite points
 *  unchanged. */
Cloud::Ptr
reduceByVoxel(const Cloud& cloud,
              double voxel_size,
              unsigned num_threads,
              const char* who,
              PickPoint pick)
{
  Cloud::Ptr out(new Cloud);
  if (!(voxel_size > 0.0)) {
    for (const std::uint32_t i : finitePoints(cloud))
      out->push_back(cloud[i]);
    return out;
  }
  pickPerVoxel(cloud, voxel_size, num_threads, who, *out, pick);
  return out;
}

/** The mean of a voxel's points, summed in double in input order. */
Eigen::Vector3d
meanOf(const Cloud& cloud, const std::uint32_t* first, const std::uint32_t* last)
{
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const std::uint32_t* i = first; i != last; ++i)
    sum += cloud[*i].getVector3fMap().cast<double>();
  return sum / static_cast<double>(last - first);
}

pcl::PointXYZ
centroidOf(const Cloud& cloud, const std::uint32_t* first, const std::uint32_t* last)
{
  const Eigen::Vector3f c = meanOf(cloud, first, last).cast<float>();
  return pcl::PointXYZ(c.x(), c.y(), c.z());
}

/** The index of the voxel's point nearest its centroid; ties: the first in input order. */
std::uint32_t
nearestToCentroidIndex(const Cloud& cloud,
                       const std::uint32_t* first,
                       const std::uint32_t* last)
{
  const Eigen::Vector3d c = meanOf(cloud, first, last);
  const std::uint32_t* best = first;
  double best_d = std::numeric_limits<double>::infinity();
  for (const std::uint32_t* i = first; i != last; ++i) {
    const double d = (cloud[*i].getVector3fMap().cast<double>() - c).squaredNorm();
    if (d < best_d)
      best_d = d, best = i;
  }
  return *best;
}

/** The voxel's point nearest its centroid. */
pcl::PointXYZ
nearestToCentroidOf(const Cloud& cloud, const std::uint32_t* first, const std::uint32_t* last)
{
  return cloud[nearestToCentroidIndex(cloud, first, last)];
}

} // namespace

Cloud::Ptr
voxelCentroid(const Cloud& cloud, double voxel_size, unsigned num_threads)
{
  return reduceByVoxel(cloud, voxel_size, num_threads, "voxelCentroid", centroidOf);
}

Cloud::Ptr
voxelNearestToCentroid(const Cloud& cloud, double voxel_size, unsigned num_threads)
{
  return reduceByVoxel(
      cloud, voxel_size, num_threads, "voxelNearestToCentroid", nearestToCentroidOf);
}

std::vector<std::uint32_t>
voxelNearestToCentroidIndices(const Cloud& cloud, double voxel_size, unsigned num_threads)
{
  if (!(voxel_size > 0.0))
    return finitePoints(cloud);
  std::vector<std::uint32_t> out;
  pickPerVoxel(cloud,
               voxel_size,
               num_threads,
               "voxelNearestToCentroidIndices",
               out,
               nearestToCentroidIndex);
  return out;
}

// ---------------------------------------------------------------------------------------
// VoxelCentroidMap

namespace {

std::size_t
hashKey(const VoxelKey& k)
{
  // The spatial hash of Teschner et al. 2003 (also KISS-ICP's voxel map).
  return static_cast<std::size_t>(static_cast<std::uint32_t>(k[0]) * 73856093u ^
                                  static_cast<std::uint32_t>(k[1]) * 19349669u ^
                                  static_cast<std::uint32_t>(k[2]) * 83492791u);
}

/** Fixed, so which thread sums a voxel never changes its arithmetic. */
constexpr std::size_t kShards = 64;
static_assert((kShards & (kShards - 1)) == 0, "centroids() merges the shards pairwise");

} // namespace

/** One shard's voxels: an open-addressing hash table (linear probing, at most half
 *  full), far cheaper per point than a node-based map at millions of voxels. */
struct VoxelCentroidMap::Shard {
  struct Slot {
    VoxelKey key;
    std::uint32_t count = 0; ///< 0: empty
    double x = 0.0, y = 0.0, z = 0.0;
  };
  std::vector<Slot> slots;
  std::size_t used = 0;

  Slot&
  find(const VoxelKey& k)
  {
    if (2 * (used + 1) > slots.size())
      grow();
    const std::size_t mask = slots.size() - 1;
    for (std::size_t i = hashKey(k) / kShards & mask;; i = (i + 1) & mask) {
      Slot& s = slots[i];
      if (s.count == 0) {
        s.key = k;
        ++used;
        return s;
      }
      if (sameKey(s.key, k))
        return s;
    }
  }
  void
  grow()
  {
    std::vector<Slot> old(std::max<std::size_t>(1024, 2 * slots.size()));
    old.swap(slots);
    used = 0;
    for (const Slot& s : old)
      if (s.count > 0)
        find(s.key) = s;
  }
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

/** A moved scan's voxels and, per shard, the voxels that fall into it (by_shard, from
 *  begin[s] to begin[s + 1]). */
struct VoxelCentroidMap::Grouped::Impl {
  double voxel_size;
  Cloud moved;
  VoxelRuns voxels;
  std::vector<std::uint32_t> begin, by_shard;
};

VoxelCentroidMap::Grouped::Grouped() = default;
VoxelCentroidMap::Grouped::~Grouped() = default;
VoxelCentroidMap::Grouped::Grouped(Grouped&&) noexcept = default;
VoxelCentroidMap::Grouped&
VoxelCentroidMap::Grouped::operator=(Grouped&&) noexcept = default;

VoxelCentroidMap::Grouped
VoxelCentroidMap::group(const Cloud& cloud,
                        const Eigen::Matrix4d& pose,
                        unsigned num_threads) const
{
  Grouped out;
  out.impl_ = std::make_unique<Grouped::Impl>();
  Grouped::Impl& s = *out.impl_;
  s.voxel_size = voxel_size_;
  pcl::transformPointCloud(cloud, s.moved, pose);
  s.voxels = groupByVoxel(s.moved, voxel_size_, num_threads, "VoxelCentroidMap");
  // The scan's voxels by shard; each shard adds its voxels' points in input order, so
  // every sum runs as it would over the concatenated scans, on any thread.
  const VoxelRuns& g = s.voxels;
  const std::size_t voxels = g.runs.size() - 1;
  std::vector<std::uint8_t> shard(voxels);
  s.begin.assign(kShards + 2, 0);
  s.by_shard.resize(voxels);
  for (std::size_t v = 0; v < voxels; ++v) {
    shard[v] = static_cast<std::uint8_t>(hashKey(g.keys[g.order[g.runs[v]]]) % kShards);
    ++s.begin[shard[v] + 2];
  }
  for (std::size_t k = 0; k <= kShards; ++k)
    s.begin[k + 1] += s.begin[k];
  for (std::size_t v = 0; v < voxels; ++v)
    s.by_shard[s.begin[shard[v] + 1]++] = static_cast<std::uint32_t>(v);
  return out;
}

void
VoxelCentroidMap::add(const Cloud& cloud, const Eigen::Matrix4d& pose)
{
  add(group(cloud, pose, num_threads_));
}

void
VoxelCentroidMap::add(Grouped&& scan)
{
  if (!scan.impl_)
    return;
  if (scan.impl_->voxel_size != voxel_size_)
    throw std::invalid_argument("VoxelCentroidMap::add: a scan grouped for another voxel size");
  const std::unique_ptr<Grouped::Impl> s = std::move(scan.impl_);
  const VoxelRuns& g = s->voxels;
  const std::size_t voxels = g.runs.size() - 1;
  const unsigned threads = resolveNumberOfThreads(num_threads_);
  parallelFor(
      kShards, voxels > 5000 ? threads : 1, 1, [&](std::size_t first, std::size_t last) {
        for (std::size_t k = first; k < last; ++k)
          for (std::uint32_t b = s->begin[k]; b < s->begin[k + 1]; ++b) {
            const std::uint32_t v = s->by_shard[b];
            auto& slot = shards_[k].find(g.keys[g.order[g.runs[v]]]);
            for (std::uint32_t i = g.runs[v]; i < g.runs[v + 1]; ++i) {
              const auto& p = s->moved[g.order[i]];
              slot.x += p.x, slot.y += p.y, slot.z += p.z;
            }
            slot.count += g.runs[v + 1] - g.runs[v];
          }
      });
}

std::size_t
VoxelCentroidMap::size() const
{
  std::size_t n = 0;
  for (const auto& s : shards_)
    n += s.used;
  return n;
}

Cloud::Ptr
VoxelCentroidMap::centroids() const
{
  // Each shard's centroids, contiguous and sorted by key, in parallel; then the sorted
  // shards merged pairwise, the merges of a level in parallel. Keys are unique, so the
  // order (and the output) is the same for any thread count and schedule.
  struct Centroid {
    VoxelKey key;
    pcl::PointXYZ p;
  };
  const auto by_key = [](const Centroid& a, const Centroid& b) {
    return keyLess(a.key, b.key);
  };
  std::vector<std::size_t> offset(kShards + 1, 0);
  for (std::size_t s = 0; s < kShards; ++s)
    offset[s + 1] = offset[s] + shards_[s].used;
  std::vector<Centroid> all(offset.back());
  const unsigned threads = resolveNumberOfThreads(num_threads_);
  const unsigned used = all.size() > 10000 ? threads : 1;
  parallelFor(kShards, used, 1, [&](std::size_t first, std::size_t last) {
    for (std::size_t s = first; s < last; ++s) {
      auto out = all.begin() + static_cast<std::ptrdiff_t>(offset[s]);
      for (const auto& slot : shards_[s].slots)
        if (slot.count > 0) {
          const double count = static_cast<double>(slot.count);
          *out++ = {slot.key,
                    pcl::PointXYZ(static_cast<float>(slot.x / count),
                                  static_cast<float>(slot.y / count),
                                  static_cast<float>(slot.z / count))};
        }
      std::sort(all.begin() + static_cast<std::ptrdiff_t>(offset[s]), out, by_key);
    }
  });
  for (std::size_t width = 1; width < kShards; width *= 2) {
    const std::size_t pairs = kShards / (2 * width);
    parallelFor(pairs, used, 1, [&](std::size_t first, std::size_t last) {
      for (std::size_t k = first; k < last; ++k) {
        const std::size_t s = k * 2 * width;
        const auto at = [&](std::size_t shard) {
          return all.begin() + static_cast<std::ptrdiff_t>(offset[shard]);
        };
        std::inplace_merge(at(s), at(s + width), at(s + 2 * width), by_key);
      }
    });
  }
  Cloud::Ptr out(new Cloud);
  out->resize(all.size());
  parallelFor(
      all.size(), used, evenGrain(all.size(), used), [&](std::size_t first, std::size_t last) {
        for (std::size_t i = first; i < last; ++i)
          (*out)[i] = all[i].p;
      });
  return out;
}

} // namespace filters
} // namespace pcl_parallel
