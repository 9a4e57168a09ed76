/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/parallel.h>

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

namespace pcl_parallel {

/** Per-thread nearest-neighbour search state, padded to a cache line (paper Sec. IV-B,
 *  class KDParams): threads of one parallel search each own one slot, indexed by
 *  omp_get_thread_num(), so a write to one thread's best match never invalidates the
 *  cache line another thread is reading. */
struct alignas(kCacheLineSize) NearestSlot {
  const float* query = nullptr; ///< query point, 3 floats
  float sqr_dist = 0.0f;        ///< squared distance of the best match so far
  std::uint32_t pos = 0;        ///< tree position of the best match so far
};
static_assert(sizeof(NearestSlot) == kCacheLineSize && alignof(NearestSlot) == kCacheLineSize,
              "one NearestSlot per cache line");

/** The same state without padding: adjacent threads share cache lines. Exists only so
 *  the benchmark can measure what the padding buys (false sharing, paper Sec. IV-B). */
struct PackedNearestSlot {
  /** The query point (x, y, z). */
  const float* query = nullptr;
  /** Squared distance of the best match so far. */
  float sqr_dist = 0.0f;
  /** Tree position of the best match so far. */
  std::uint32_t pos = 0;
};

/** Which slot layout a batch search uses (benchmark knob; padded is the default). */
enum class SlotLayout { kPadded, kPacked };

/**
 * \brief Exact k-d tree over 3D float points (paper Sec. IV-A), the engine behind
 * pcl_parallel::search::KdTree, the correspondence estimation, pICP and pLUM.
 *
 * - Layout: a flat node array in depth-first order (left child follows its parent);
 *   points are copied into leaf order, so a bucket is one contiguous run of floats. A
 *   merge() leaves several such trees (parts) in the arrays, searched root by root.
 * - Split rule: the median along the axis of largest extent (Friedman, Bentley and Finkel,
 *   paper ref. [8]). Median splits keep the tree balanced, so its shape and its node
 *   positions are a function of the point count alone, which lets the two halves be built
 *   by concurrent OpenMP tasks into a preallocated array (Sec. IV-A.2) and makes the tree
 *   identical for every thread count.
 * - Buckets hold at most bucket_size points (default 12, see docs/benchmarks.md). A
 *   node whose points all coincide becomes one leaf however large, searched by its first
 *   point(s) only, so clouds of duplicates cost O(1) per query instead of O(n).
 * - Search is exact. The bounds-overlap-ball test (Sec. IV-A.3) uses the incremental
 *   distance of Arya and Mount: each inner node stores the largest coordinate of its left
 *   half and the smallest of its right half, and a far child is visited only while the
 *   squared distance to its cell can still beat the best match.
 *
 * Non-finite points are skipped at build time; the tree reports positions (0..size()-1,
 * leaf order) that map to the caller's ids through id(). All const members are safe to
 * call concurrently.
 */
class KdTreeIndex {
public:
  /** Shared pointer to a tree. */
  using Ptr = std::shared_ptr<KdTreeIndex>;
  /** Shared pointer to a const tree. */
  using ConstPtr = std::shared_ptr<const KdTreeIndex>;

  /** "No point": a position or index that names none. */
  static constexpr std::uint32_t kInvalid = std::numeric_limits<std::uint32_t>::max();
  /** The default bucket size (points per leaf). */
  static constexpr unsigned kDefaultBucketSize = 12;

  /** Builds the tree. \a xyz holds \a n points with \a stride floats between consecutive
   *  points (x, y, z first); \a ids (may be null: ids are then 0..n-1) are what id()
   *  reports back. Non-finite points are left out. \a num_threads as in
   *  resolveNumberOfThreads(). Throws std::invalid_argument for bucket_size == 0 or when
   *  checkCapacity() fails. */
  void
  build(const float* xyz,
        std::size_t n,
        std::size_t stride,
        const std::uint32_t* ids = nullptr,
        unsigned num_threads = 0,
        unsigned bucket_size = kDefaultBucketSize);

  /** A tree over some of \a base's points and all of \a added's, without a build: for a
   *  point set that changes a little at a time (slam::LocalMap), current at the cost of a
   *  tree over the new points and a copy. \a renamed maps each of base's ids to the id
   *  the point has now, or to kInvalid where the point is gone; \a added's ids are kept.
   *  base's nodes stay, with its dropped points left out of their leaves (its splits still
   *  bound the points that stay), and added's follow as a second part; searches visit
   *  base's part first (ties keep the first point found). Throws std::invalid_argument
   *  unless \a renamed holds an entry for every id of base, or when the result does not
   *  fit the uint32 positions and node indices. */
  static KdTreeIndex
  merge(const KdTreeIndex& base,
        const std::vector<std::uint32_t>& renamed,
        const KdTreeIndex& added);

  /** Number of separately built parts: 1 for a built tree (0 when empty), more after
   *  merge(). */
  std::size_t
  numParts() const
  {
    return roots_.size();
  }

  /** Throws std::invalid_argument unless a tree of n points and this bucket size fits the
   *  uint32 indices: n <= 2^32-2 points and fewer than 2^32-1 node slots (~2n/bucket_size,
   *  so a bucket size of 1 caps n near 2^31). build() checks the finite points' count. */
  static void
  checkCapacity(std::size_t n, unsigned bucket_size);

  /** Number of (finite) points in the tree. */
  std::size_t
  size() const
  {
    return ids_.size();
  }
  /** True when the tree holds no point. */
  bool
  empty() const
  {
    return ids_.empty();
  }
  /** Number of nodes of the flat tree. */
  std::size_t
  numNodes() const
  {
    return nodes_.size();
  }
  /** Heap bytes the tree holds (nodes, its copy of the points, ids): ~16 + 16·2/bucket
   *  bytes a point (docs/benchmarks.md, "Memory"). */
  std::size_t
  memoryBytes() const
  {
    return nodes_.capacity() * sizeof(Node) + points_.capacity() * sizeof(float) +
           ids_.capacity() * sizeof(std::uint32_t);
  }
  /** Largest number of points per leaf. */
  unsigned
  bucketSize() const
  {
    return bucket_size_;
  }

  /** Caller's id of the point at tree position \a pos. */
  std::uint32_t
  id(std::uint32_t pos) const
  {
    return ids_[pos];
  }
  /** Coordinates (x, y, z) of the point at tree position \a pos. */
  const float*
  point(std::uint32_t pos) const
  {
    return &points_[3 * static_cast<std::size_t>(pos)];
  }

  /** Nearest neighbour of \a query with squared distance <= \a max_sqr_dist (inclusive,
   *  as PCL's correspondence estimation). Returns its position, or kInvalid if there is
   *  none; \a sqr_dist receives its squared distance.
   *
   *  Warm start: \a hint is a position expected to be close (e.g. last iteration's match
   *  of this query in ICP). Its distance bounds the search from the start, which prunes
   *  most of the tree; the answer stays exact. Equidistant points may then be resolved
   *  differently (ties keep the first point found). */
  std::uint32_t
  nearest(const float* query,
          float max_sqr_dist,
          float& sqr_dist,
          std::uint32_t hint = kInvalid) const;

  /** Same search, with the state in a caller-owned slot (slot.query set; slot.sqr_dist
   *  and slot.pos are overwritten). This is what parallel loops call with their thread's
   *  padded slot. Returns slot.pos. */
  std::uint32_t
  nearest(NearestSlot& slot, float max_sqr_dist, std::uint32_t hint = kInvalid) const;
  /** nearest() on the unpadded slot (the benchmark's comparison; paper Sec. IV-B). */
  std::uint32_t
  nearest(PackedNearestSlot& slot, float max_sqr_dist, std::uint32_t hint = kInvalid) const;

  /** Parallel nearest neighbours of \a n queries (stride as in build()). out_pos[i] is
   *  kInvalid where no point lies within max_sqr_dist or the query is not finite. */
  void
  nearestBatch(const float* queries,
               std::size_t n,
               std::size_t stride,
               float max_sqr_dist,
               std::uint32_t* out_pos,
               float* out_sqr_dist,
               unsigned num_threads = 0,
               SlotLayout layout = SlotLayout::kPadded) const;

  /** The k nearest neighbours, closest first. Writes at most k entries; returns how many. */
  std::size_t
  knn(const float* query, std::size_t k, std::uint32_t* out_pos, float* out_sqr_dist) const;

  /** All points with squared distance <= \a sqr_radius; at most max_nn (0: no limit),
   *  which are then the closest ones when \a sorted, else arbitrary ones. Sorted closest
   *  first when \a sorted. Output vectors are overwritten. */
  std::size_t
  radius(const float* query,
         float sqr_radius,
         std::vector<std::uint32_t>& out_pos,
         std::vector<float>& out_sqr_dist,
         std::size_t max_nn = 0,
         bool sorted = true) const;

private:
  /** Node of the flat tree. Inner nodes: axis 0..2, children at this+1 and right. */
  struct Node {
    /** An inner node's split planes. */
    struct Split {
      float lo; ///< largest coordinate along axis in the left child
      float hi; ///< smallest coordinate along axis in the right child
    };
    /** A leaf's points: tree positions [begin, end). */
    struct Leaf {
      /** First tree position of the leaf. */
      std::uint32_t begin;
      /** One past its last tree position. */
      std::uint32_t end;
    };
    union {
      Split split;
      Leaf leaf;
    };
    std::uint32_t right; ///< inner: index of the right child
    std::uint32_t kind;  ///< 0..2: inner node's split axis; kLeaf; kDuplicateLeaf
  };
  static constexpr std::uint32_t kLeaf = 3;
  static constexpr std::uint32_t kDuplicateLeaf = 4; ///< all points of the leaf coincide

  struct Builder;
  std::uint32_t
  compactNodes(std::uint32_t node, std::vector<Node>& out) const;

  /** A built part's root within nodes_ and the bounds of its points as built. */
  struct Root {
    std::uint32_t node;
    float min[3];
    float max[3];
  };
  static float
  rootDistance(const Root& root, const float* q, float* off);
  /** search() from each root whose bounds the result can still reach. */
  template <typename Result>
  void
  searchRoots(const float* q, Result& result) const;
  template <typename Result>
  void
  scanLeaf(const Node& node, const float* q, Result& result) const;
  template <typename Result>
  void
  search(
      std::uint32_t node, const float* q, float min_sqr_dist, float* off, Result& result) const;
  template <typename Slot>
  std::uint32_t
  nearestImpl(Slot& slot, float max_sqr_dist, std::uint32_t hint) const;
  template <typename Slot>
  void
  nearestBatchImpl(const float* queries,
                   std::size_t n,
                   std::size_t stride,
                   float max_sqr_dist,
                   std::uint32_t* out_pos,
                   float* out_sqr_dist,
                   unsigned num_threads) const;

  std::vector<Node> nodes_;
  std::vector<float> points_;      ///< 3 floats per point, in leaf order
  std::vector<std::uint32_t> ids_; ///< caller's id per position
  std::vector<Root> roots_;        ///< one per built part; none when empty
  unsigned bucket_size_ = kDefaultBucketSize;
};

} // namespace pcl_parallel
