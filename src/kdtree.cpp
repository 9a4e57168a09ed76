/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/kdtree.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

namespace pcl_parallel {

namespace {

/** A far cell is searched while (lower bound * kBoundSlack) can beat the best match.
 *  The bound is sqrNorm of per-axis offsets fl(q - plane), each no longer than the
 *  rounded fl(q - p) of any point p beyond that plane (rounding is monotone), summed in
 *  sqrDist's order: so it never exceeds any of the cell's computed distances (proof in
 *  docs/design.md). The slack only covers a compiler that contracts one of the two sums
 *  into FMAs and not the other (<= 2 roundings each, 4 ulp in all). */
constexpr float kBoundSlack = 1.0f - 8.0f * std::numeric_limits<float>::epsilon();

/** A range of at most this many points is built as one subtree by one thread. */
constexpr std::uint32_t kMinSubtreePoints = 4096;

inline float
sqrDist(const float* a, const float* b)
{
  const float dx = a[0] - b[0];
  const float dy = a[1] - b[1];
  const float dz = a[2] - b[2];
  return dx * dx + dy * dy + dz * dz;
}

/** |o|², summed exactly as sqrDist sums (same operations, same order). */
inline float
sqrNorm(const float* o)
{
  return o[0] * o[0] + o[1] * o[1] + o[2] * o[2];
}

inline bool
isFinite3(const float* p)
{
  return std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]);
}

/** Node slots of a subtree over n points, f(n) = 1 for n <= B, else
 *  1 + f(floor(n/2)) + f(ceil(n/2)). Returns {f(n), f(n+1)}; O(log n). */
std::pair<std::size_t, std::size_t>
slotPair(std::size_t n, std::size_t bucket)
{
  if (n + 1 <= bucket)
    return {1, 1};
  if (n <= bucket) // n == B: B+1 points split into two leaves
    return {1, 3};
  const std::size_t m = n / 2;
  const auto [fm, fm1] = slotPair(m, bucket);
  if (n % 2 == 0)
    return {1 + 2 * fm, 1 + fm + fm1};
  return {1 + fm + fm1, 1 + 2 * fm1};
}

std::size_t
slotsFor(std::size_t n, std::size_t bucket)
{
  return slotPair(n, bucket).first;
}

// Result policies for the one traversal in KdTreeIndex::search().

/** Nearest neighbour: state in a (padded or packed) per-thread slot. */
template <typename Slot>
struct NearestResult {
  Slot& slot;
  bool
  canImprove(float lower_bound) const
  {
    return lower_bound * kBoundSlack < slot.sqr_dist;
  }
  static std::uint32_t
  leafLimit(std::uint32_t)
  {
    return 1;
  }
  void
  offer(float d2, std::uint32_t pos)
  {
    if (d2 < slot.sqr_dist) {
      slot.sqr_dist = d2;
      slot.pos = pos;
    }
  }
};

/** k nearest: a sorted array of at most k entries, closest first. */
struct KnnResult {
  std::size_t k;
  std::uint32_t* pos;
  float* d2;
  std::size_t count = 0;

  float
  worst() const
  {
    return count < k ? std::numeric_limits<float>::infinity() : d2[count - 1];
  }
  bool
  canImprove(float lower_bound) const
  {
    return lower_bound * kBoundSlack < worst();
  }
  std::uint32_t
  leafLimit(std::uint32_t n) const
  {
    return static_cast<std::uint32_t>(std::min<std::size_t>(n, k));
  }
  void
  offer(float dist, std::uint32_t p)
  {
    if (!(dist < worst()))
      return;
    std::size_t i = count < k ? count++ : k - 1;
    // Insert after equal distances: ties keep the order in which they were found.
    for (; i > 0 && d2[i - 1] > dist; --i) {
      d2[i] = d2[i - 1];
      pos[i] = pos[i - 1];
    }
    d2[i] = dist;
    pos[i] = p;
  }
};

/** Fixed radius: every point with d2 <= r2 (inclusive, as FLANN). */
struct RadiusResult {
  float r2;
  std::vector<std::uint32_t>& pos;
  std::vector<float>& d2;

  bool
  canImprove(float lower_bound) const
  {
    return lower_bound * kBoundSlack <= r2;
  }
  static std::uint32_t
  leafLimit(std::uint32_t n)
  {
    return n;
  }
  void
  offer(float dist, std::uint32_t p)
  {
    if (dist <= r2) {
      pos.push_back(p);
      d2.push_back(dist);
    }
  }
};

/** A point during the build: partitioned in place, so the split scans and nth_element
 *  walk contiguous memory instead of chasing an index permutation. */
struct BuildPoint {
  float p[3];
  std::uint32_t id;
};

} // namespace

/** Build state of one build(): disjoint ranges of pts are partitioned concurrently; each
 *  node's slot is known in advance (slotsFor), so no two workers write the same node. */
struct KdTreeIndex::Builder {
  /** A node still to be built over pts[begin, end). */
  struct Range {
    std::uint32_t node, begin, end;
  };

  KdTreeIndex& tree;
  BuildPoint* pts;

  /** Makes `node` a leaf (returns false) or splits its range at the median of its widest
   *  axis into [begin, mid) at node + 1 and [mid, end) at `right` (returns true). */
  bool
  makeNode(const Range& r, std::uint32_t& mid, std::uint32_t& right)
  {
    float lo[3], hi[3];
    for (int a = 0; a < 3; ++a)
      lo[a] = hi[a] = pts[r.begin].p[a];
    for (std::uint32_t i = r.begin + 1; i < r.end; ++i)
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], pts[i].p[a]);
        hi[a] = std::max(hi[a], pts[i].p[a]);
      }
    std::uint32_t axis = 0;
    for (std::uint32_t a = 1; a < 3; ++a)
      if (hi[a] - lo[a] > hi[axis] - lo[axis])
        axis = a;

    Node& nd = tree.nodes_[r.node];
    const std::uint32_t n = r.end - r.begin;
    const bool coincident = hi[axis] - lo[axis] == 0.0f;
    if (n <= tree.bucket_size_ || coincident) {
      nd.kind = coincident && n > 1 ? kDuplicateLeaf : kLeaf;
      nd.leaf = {r.begin, r.end};
      return false;
    }

    mid = r.begin + n / 2;
    std::nth_element(
        pts + r.begin,
        pts + mid,
        pts + r.end,
        [axis](const BuildPoint& a, const BuildPoint& b) { return a.p[axis] < b.p[axis]; });
    float left_max = pts[r.begin].p[axis];
    for (std::uint32_t i = r.begin + 1; i < mid; ++i)
      left_max = std::max(left_max, pts[i].p[axis]);

    nd.kind = axis;
    nd.split = {left_max, pts[mid].p[axis]};
    nd.right =
        r.node + 1 + static_cast<std::uint32_t>(slotsFor(mid - r.begin, tree.bucket_size_));
    right = nd.right;
    return true;
  }

  void
  buildSubtree(const Range& r)
  {
    std::uint32_t mid, right;
    if (makeNode(r, mid, right)) {
      buildSubtree({r.node + 1, r.begin, mid});
      buildSubtree({right, mid, r.end});
    }
  }

  /** Sec. IV-A.2: the two halves of a split are disjoint, so they are built concurrently.
   *  The top levels are split breadth-first, one parallel loop per level, until every range
   *  has at most subtree_points points; those subtrees are then built in one dynamic loop.
   *  (Plain loops rather than tasks: ThreadSanitizer sees their synchronisation, and the
   *  tree does not depend on the schedule either way.) */
  void
  buildParallel(std::uint32_t m, std::uint32_t subtree_points, unsigned threads)
  {
    std::vector<Range> level{{0, 0, m}}, subtrees;
    while (!level.empty()) {
      std::vector<Range> children(2 * level.size(), Range{kInvalid, 0, 0});
      parallelFor(level.size(), threads, 1, [&](std::size_t first, std::size_t last) {
        for (std::size_t i = first; i < last; ++i) {
          const Range& r = level[i];
          std::uint32_t mid, right;
          if (r.end - r.begin > subtree_points && makeNode(r, mid, right)) {
            children[2 * i] = {r.node + 1, r.begin, mid};
            children[2 * i + 1] = {right, mid, r.end};
          }
        }
      });
      std::vector<Range> next;
      for (std::size_t i = 0; i < level.size(); ++i) {
        if (level[i].end - level[i].begin <= subtree_points)
          subtrees.push_back(level[i]);
        for (std::size_t c = 2 * i; c < 2 * i + 2; ++c)
          if (children[c].node != kInvalid)
            next.push_back(children[c]);
      }
      level.swap(next);
    }
    parallelFor(subtrees.size(), threads, 1, [&](std::size_t first, std::size_t last) {
      for (std::size_t i = first; i < last; ++i)
        buildSubtree(subtrees[i]);
    });
  }
};

void
KdTreeIndex::checkCapacity(std::size_t n, unsigned bucket_size)
{
  if (bucket_size == 0)
    throw std::invalid_argument("pcl_parallel::KdTreeIndex: bucket size must be at least 1");
  // Point positions and node indices are uint32 with kInvalid reserved.
  if (n >= kInvalid)
    throw std::invalid_argument("pcl_parallel::KdTreeIndex: " + std::to_string(n) +
                                " points, more than uint32 indices hold (4294967294)");
  const std::size_t slots = slotsFor(n, bucket_size);
  if (slots >= kInvalid)
    throw std::invalid_argument("pcl_parallel::KdTreeIndex: " + std::to_string(n) +
                                " points in buckets of " + std::to_string(bucket_size) +
                                " need " + std::to_string(slots) +
                                " nodes, more than uint32 indices hold; use larger buckets");
}

void
KdTreeIndex::build(const float* xyz,
                   std::size_t n,
                   std::size_t stride,
                   const std::uint32_t* ids,
                   unsigned num_threads,
                   unsigned bucket_size)
{
  if (bucket_size == 0)
    throw std::invalid_argument("pcl_parallel::KdTreeIndex: bucket size must be at least 1");
  if (n > 0 && (xyz == nullptr || stride < 3))
    throw std::invalid_argument("pcl_parallel::KdTreeIndex: need 3 floats per point");
  checkCapacity(n, bucket_size);

  bucket_size_ = bucket_size;
  const unsigned threads = resolveNumberOfThreads(num_threads);

  std::vector<BuildPoint> pts;
  pts.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float* p = xyz + i * stride;
    if (isFinite3(p))
      pts.push_back({{p[0], p[1], p[2]}, ids ? ids[i] : static_cast<std::uint32_t>(i)});
  }
  const auto m = static_cast<std::uint32_t>(pts.size());

  nodes_.clear();
  points_.clear();
  ids_.clear();
  roots_.clear();
  if (m == 0)
    return;
  Root root{
      0, {pts[0].p[0], pts[0].p[1], pts[0].p[2]}, {pts[0].p[0], pts[0].p[1], pts[0].p[2]}};
  for (const BuildPoint& q : pts)
    for (int a = 0; a < 3; ++a) {
      root.min[a] = std::min(root.min[a], q.p[a]);
      root.max[a] = std::max(root.max[a], q.p[a]);
    }
  roots_.push_back(root);

  checkCapacity(m, bucket_size_);
  nodes_.resize(slotsFor(m, bucket_size_));
  // Split down to ~8 subtrees per thread (and never below kMinSubtreePoints points): enough
  // to balance, few enough that the per-level loops' overhead stays negligible.
  Builder builder{*this, pts.data()};
  const std::uint32_t subtree_points = std::max(kMinSubtreePoints, m / (8 * threads));
  if (threads > 1 && m > subtree_points)
    builder.buildParallel(m, subtree_points, threads);
  else
    builder.buildSubtree({0, 0, m});

  // Subtrees of coincident points end early and leave unused slots: drop them.
  std::vector<Node> compact;
  compact.reserve(nodes_.size());
  compactNodes(0, compact);
  nodes_.swap(compact);

  points_.resize(3 * std::size_t{m});
  ids_.resize(m);
  parallelFor(m, threads, evenGrain(m, threads), [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      std::copy_n(pts[i].p, 3, &points_[3 * i]);
      ids_[i] = pts[i].id;
    }
  });
}

std::uint32_t
KdTreeIndex::compactNodes(std::uint32_t node, std::vector<Node>& out) const
{
  const auto at = static_cast<std::uint32_t>(out.size());
  out.push_back(nodes_[node]);
  if (nodes_[node].kind < kLeaf) {
    compactNodes(node + 1, out); // lands at at + 1: depth-first order is kept
    const std::uint32_t right = compactNodes(nodes_[node].right, out);
    out[at].right = right;
  }
  return at;
}

KdTreeIndex
KdTreeIndex::merge(const KdTreeIndex& base,
                   const std::vector<std::uint32_t>& renamed,
                   const KdTreeIndex& added)
{
  const std::size_t nodes = base.nodes_.size() + added.nodes_.size();
  if (base.size() + added.size() >= kInvalid || nodes >= kInvalid)
    throw std::invalid_argument(
        "pcl_parallel::KdTreeIndex::merge: " + std::to_string(base.size() + added.size()) +
        " points in " + std::to_string(nodes) + " nodes, more than uint32 indices hold");
  KdTreeIndex out;
  out.nodes_.reserve(nodes);
  out.points_.reserve(base.points_.size() + added.points_.size());
  out.ids_.reserve(base.size() + added.size());
  // Nodes are in depth-first order and points in leaf order, so the leaves come in
  // position order: each keeps its renamed points, moved up to close the gaps.
  for (Node nd : base.nodes_) {
    if (nd.kind >= kLeaf) {
      const auto begin = static_cast<std::uint32_t>(out.ids_.size());
      for (std::uint32_t p = nd.leaf.begin; p < nd.leaf.end; ++p) {
        const std::uint32_t id = base.ids_[p];
        if (id >= renamed.size())
          throw std::invalid_argument("pcl_parallel::KdTreeIndex::merge: id " +
                                      std::to_string(id) + " has no entry in renamed (" +
                                      std::to_string(renamed.size()) + " entries)");
        if (renamed[id] == kInvalid)
          continue;
        out.ids_.push_back(renamed[id]);
        const float* q = base.point(p);
        out.points_.insert(out.points_.end(), q, q + 3);
      }
      nd.leaf = {begin, static_cast<std::uint32_t>(out.ids_.size())};
      if (nd.leaf.end - nd.leaf.begin < 2)
        nd.kind = kLeaf; // a duplicate leaf is searched by its first point, if any
    }
    out.nodes_.push_back(nd);
  }
  out.roots_ = base.roots_;

  const auto node_offset = static_cast<std::uint32_t>(out.nodes_.size());
  const auto pos_offset = static_cast<std::uint32_t>(out.size());
  for (Node nd : added.nodes_) {
    if (nd.kind >= kLeaf)
      nd.leaf = {nd.leaf.begin + pos_offset, nd.leaf.end + pos_offset};
    else
      nd.right += node_offset;
    out.nodes_.push_back(nd);
  }
  out.points_.insert(out.points_.end(), added.points_.begin(), added.points_.end());
  out.ids_.insert(out.ids_.end(), added.ids_.begin(), added.ids_.end());
  for (Root root : added.roots_) {
    root.node += node_offset;
    out.roots_.push_back(root);
  }
  out.bucket_size_ = std::max(base.bucket_size_, added.bucket_size_);
  return out;
}

float
KdTreeIndex::rootDistance(const Root& root, const float* q, float* off)
{
  for (int a = 0; a < 3; ++a)
    off[a] = q[a] < root.min[a]   ? root.min[a] - q[a]
             : q[a] > root.max[a] ? q[a] - root.max[a]
                                  : 0.0f;
  return sqrNorm(off);
}

template <typename Result>
void
KdTreeIndex::searchRoots(const float* q, Result& result) const
{
  float off[3];
  for (const Root& root : roots_) {
    const float d2 = rootDistance(root, q, off);
    if (result.canImprove(d2))
      search(root.node, q, d2, off, result);
  }
}

template <typename Result>
void
KdTreeIndex::scanLeaf(const Node& node, const float* q, Result& result) const
{
  const std::uint32_t count = node.leaf.end - node.leaf.begin;
  // A duplicate leaf's points coincide: its first leafLimit() points stand for all.
  const std::uint32_t end =
      node.kind == kDuplicateLeaf ? node.leaf.begin + result.leafLimit(count) : node.leaf.end;
  const float* p = &points_[3 * static_cast<std::size_t>(node.leaf.begin)];
  for (std::uint32_t i = node.leaf.begin; i < end; ++i, p += 3)
    result.offer(sqrDist(q, p), i);
}

template <typename Result>
void
KdTreeIndex::search(
    std::uint32_t node, const float* q, float min_sqr_dist, float* off, Result& result) const
{
  const Node& nd = nodes_[node];
  if (nd.kind >= kLeaf) {
    scanLeaf(nd, q, result);
    return;
  }
  const std::uint32_t axis = nd.kind;
  const float to_left = q[axis] - nd.split.lo;  // >= 0: query is right of the left half
  const float to_right = q[axis] - nd.split.hi; // <= 0: query is left of the right half
  std::uint32_t near_child = node + 1, far_child = nd.right;
  float cut = to_right;
  if (to_left + to_right >= 0.0f) {
    std::swap(near_child, far_child);
    cut = to_left;
  }
  search(near_child, q, min_sqr_dist, off, result);

  // Distance to the far cell: this axis' offset replaced by the cut, summed from scratch
  // (Arya and Mount's incremental old² - cut² update can cancel and overshoot).
  const float old = off[axis];
  off[axis] = cut;
  const float far_sqr_dist = sqrNorm(off);
  if (result.canImprove(far_sqr_dist))
    search(far_child, q, far_sqr_dist, off, result);
  off[axis] = old;
}

template <typename Slot>
std::uint32_t
KdTreeIndex::nearestImpl(Slot& slot, float max_sqr_dist, std::uint32_t hint) const
{
  const float* q = slot.query;
  slot.pos = kInvalid;
  // Accept d2 <= max_sqr_dist through the strict test d2 < sqr_dist.
  slot.sqr_dist = std::nextafter(max_sqr_dist, std::numeric_limits<float>::infinity());
  if (empty() || !isFinite3(q) || !(max_sqr_dist >= 0.0f)) {
    slot.sqr_dist = std::numeric_limits<float>::infinity();
    return kInvalid;
  }
  if (hint < size()) {
    const float d2 = sqrDist(q, point(hint));
    if (d2 <= max_sqr_dist) {
      slot.sqr_dist = d2;
      slot.pos = hint;
    }
  }
  NearestResult<Slot> result{slot};
  searchRoots(q, result);
  if (slot.pos == kInvalid)
    slot.sqr_dist = std::numeric_limits<float>::infinity();
  return slot.pos;
}

std::uint32_t
KdTreeIndex::nearest(const float* query,
                     float max_sqr_dist,
                     float& sqr_dist,
                     std::uint32_t hint) const
{
  PackedNearestSlot slot; // private to this call: no sharing, no padding needed
  slot.query = query;
  nearestImpl(slot, max_sqr_dist, hint);
  sqr_dist = slot.sqr_dist;
  return slot.pos;
}

std::uint32_t
KdTreeIndex::nearest(NearestSlot& slot, float max_sqr_dist, std::uint32_t hint) const
{
  return nearestImpl(slot, max_sqr_dist, hint);
}

std::uint32_t
KdTreeIndex::nearest(PackedNearestSlot& slot, float max_sqr_dist, std::uint32_t hint) const
{
  return nearestImpl(slot, max_sqr_dist, hint);
}

template <typename Slot>
void
KdTreeIndex::nearestBatchImpl(const float* queries,
                              std::size_t n,
                              std::size_t stride,
                              float max_sqr_dist,
                              std::uint32_t* out_pos,
                              float* out_sqr_dist,
                              unsigned num_threads) const
{
  const unsigned threads = resolveNumberOfThreads(num_threads);
  // One slot per thread, indexed by parallelFor's slot (paper Sec. IV-B).
  std::vector<Slot> slots(threads);
  parallelFor(n, threads, 256, [&](std::size_t first, std::size_t last, unsigned t) {
    Slot& slot = slots[t];
    for (std::size_t i = first; i < last; ++i) {
      slot.query = queries + i * stride;
      out_pos[i] = nearestImpl(slot, max_sqr_dist, kInvalid);
      if (out_sqr_dist)
        out_sqr_dist[i] = slot.sqr_dist;
    }
  });
}

void
KdTreeIndex::nearestBatch(const float* queries,
                          std::size_t n,
                          std::size_t stride,
                          float max_sqr_dist,
                          std::uint32_t* out_pos,
                          float* out_sqr_dist,
                          unsigned num_threads,
                          SlotLayout layout) const
{
  if (n > 0 && (queries == nullptr || stride < 3 || out_pos == nullptr))
    throw std::invalid_argument("pcl_parallel::KdTreeIndex::nearestBatch: bad arguments");
  if (layout == SlotLayout::kPadded)
    nearestBatchImpl<NearestSlot>(
        queries, n, stride, max_sqr_dist, out_pos, out_sqr_dist, num_threads);
  else
    nearestBatchImpl<PackedNearestSlot>(
        queries, n, stride, max_sqr_dist, out_pos, out_sqr_dist, num_threads);
}

std::size_t
KdTreeIndex::knn(const float* query,
                 std::size_t k,
                 std::uint32_t* out_pos,
                 float* out_sqr_dist) const
{
  if (k == 0 || empty() || !isFinite3(query))
    return 0;
  KnnResult result{k, out_pos, out_sqr_dist};
  searchRoots(query, result);
  return result.count;
}

std::size_t
KdTreeIndex::radius(const float* query,
                    float sqr_radius,
                    std::vector<std::uint32_t>& out_pos,
                    std::vector<float>& out_sqr_dist,
                    std::size_t max_nn,
                    bool sorted) const
{
  out_pos.clear();
  out_sqr_dist.clear();
  if (empty() || !isFinite3(query) || !(sqr_radius >= 0.0f))
    return 0;
  RadiusResult result{sqr_radius, out_pos, out_sqr_dist};
  searchRoots(query, result);

  const std::size_t found = out_pos.size();
  const std::size_t keep = max_nn > 0 ? std::min(max_nn, found) : found;
  if (sorted) {
    std::vector<std::uint32_t> order(found);
    std::iota(order.begin(), order.end(), 0u);
    const auto closer = [&](std::uint32_t a, std::uint32_t b) {
      return out_sqr_dist[a] < out_sqr_dist[b] ||
             (out_sqr_dist[a] == out_sqr_dist[b] && out_pos[a] < out_pos[b]);
    };
    std::partial_sort(order.begin(), order.begin() + keep, order.end(), closer);
    std::vector<std::uint32_t> pos(keep);
    std::vector<float> d2(keep);
    for (std::size_t i = 0; i < keep; ++i) {
      pos[i] = out_pos[order[i]];
      d2[i] = out_sqr_dist[order[i]];
    }
    out_pos.swap(pos);
    out_sqr_dist.swap(d2);
  }
  else {
    out_pos.resize(keep);
    out_sqr_dist.resize(keep);
  }
  return keep;
}

} // namespace pcl_parallel
