/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * KdTreeIndex against brute force: random, clustered and degenerate clouds, every
 * search kind, warm starts, bucket sizes and thread counts.
 */
#include "random_clouds.h"

#include <pcl_parallel/kdtree.h>

#include <gtest/gtest.h>
#include <numeric>
#include <random>

using pcl_parallel::KdTreeIndex;
using namespace pcl_parallel::test;

namespace {

KdTreeIndex
buildTree(const pcl::PointCloud<pcl::PointXYZ>& cloud,
          unsigned threads = 1,
          unsigned bucket = KdTreeIndex::kDefaultBucketSize)
{
  KdTreeIndex tree;
  tree.build(
      cloud.empty() ? nullptr : cloud.front().data, cloud.size(), 4, nullptr, threads, bucket);
  return tree;
}

/** Checks NN (with and without a distance limit) and kNN for queries against brute force. */
void
expectMatchesBruteForce(const KdTreeIndex& tree,
                        const pcl::PointCloud<pcl::PointXYZ>& cloud,
                        const pcl::PointCloud<pcl::PointXYZ>& queries,
                        float max_sqr)
{
  for (std::size_t i = 0; i < queries.size(); ++i) {
    const auto& q = queries[i];
    float d2 = -1.0f;
    const std::uint32_t pos = tree.nearest(q.data, max_sqr, d2);
    const auto [bi, bd2] = bruteNearest(q, cloud, max_sqr);
    if (bi < 0) {
      EXPECT_EQ(pos, KdTreeIndex::kInvalid) << "query " << i;
      continue;
    }
    ASSERT_NE(pos, KdTreeIndex::kInvalid) << "query " << i;
    EXPECT_EQ(d2, bd2) << "query " << i;
    // The match is a point of the cloud at that distance (ties may pick another index).
    const auto& m = cloud[tree.id(pos)];
    const float dx = q.x - m.x, dy = q.y - m.y, dz = q.z - m.z;
    EXPECT_EQ(dx * dx + dy * dy + dz * dz, bd2);
  }
}

void
expectKnnMatchesBruteForce(const KdTreeIndex& tree,
                           const pcl::PointCloud<pcl::PointXYZ>& cloud,
                           const pcl::PointCloud<pcl::PointXYZ>& queries,
                           std::size_t k)
{
  std::vector<std::uint32_t> pos(k);
  std::vector<float> d2(k);
  for (const auto& q : queries) {
    const auto all = bruteSortedDistances(q, cloud);
    const std::size_t found = tree.knn(q.data, k, pos.data(), d2.data());
    ASSERT_EQ(found, std::min(k, all.size()));
    for (std::size_t j = 0; j < found; ++j)
      EXPECT_EQ(d2[j], all[j]) << "rank " << j;
  }
}

void
expectRadiusMatchesBruteForce(const KdTreeIndex& tree,
                              const pcl::PointCloud<pcl::PointXYZ>& cloud,
                              const pcl::PointCloud<pcl::PointXYZ>& queries,
                              float r2)
{
  std::vector<std::uint32_t> pos;
  std::vector<float> d2;
  for (const auto& q : queries) {
    auto all = bruteSortedDistances(q, cloud);
    all.erase(std::upper_bound(all.begin(), all.end(), r2), all.end());
    tree.radius(q.data, r2, pos, d2);
    ASSERT_EQ(d2.size(), all.size());
    EXPECT_EQ(d2, all);
    // max_nn keeps the closest ones when sorted
    if (all.size() > 3) {
      tree.radius(q.data, r2, pos, d2, 3, true);
      EXPECT_EQ(d2, std::vector<float>(all.begin(), all.begin() + 3));
    }
  }
}

} // namespace

TEST(KdTreeIndex, UniformCloudMatchesBruteForce)
{
  const auto cloud = uniformCloud(5000, 1);
  const auto queries = uniformCloud(500, 2);
  for (unsigned bucket : {1u, 2u, 6u, 32u}) {
    SCOPED_TRACE(bucket);
    const auto tree = buildTree(cloud, 1, bucket);
    EXPECT_EQ(tree.size(), cloud.size());
    expectMatchesBruteForce(tree, cloud, queries, std::numeric_limits<float>::infinity());
    expectMatchesBruteForce(tree, cloud, queries, 0.0025f);
    expectKnnMatchesBruteForce(tree, cloud, queries, 7);
    expectRadiusMatchesBruteForce(tree, cloud, queries, 0.02f);
  }
}

TEST(KdTreeIndex, ClusteredCloudMatchesBruteForce)
{
  const auto cloud = clusteredCloud(20000, 3);
  auto queries = clusteredCloud(300, 4);
  for (const auto& p : uniformCloud(200, 5)) // queries far from any cluster too
    queries.push_back(pcl::PointXYZ(p.x * 20, p.y * 20, p.z * 20));
  const auto tree = buildTree(cloud, 2);
  expectMatchesBruteForce(tree, cloud, queries, std::numeric_limits<float>::infinity());
  expectMatchesBruteForce(tree, cloud, queries, 0.01f);
  expectKnnMatchesBruteForce(tree, cloud, queries, 1);
  expectKnnMatchesBruteForce(tree, cloud, queries, 20);
  expectRadiusMatchesBruteForce(tree, cloud, queries, 0.05f);
}

// A tree merged from a built one (some points dropped, the rest renamed) and one over
// points added later (the local map after a scan) answers as a tree over the points that
// are there now: nearest (with their ids now), kNN and radius. Coincident points, some
// dropped, test the duplicate leaves that lose their first points.
TEST(KdTreeIndex, MergedTreeMatchesBruteForceOverThePointsNow)
{
  auto base = clusteredCloud(20000, 3);
  const pcl::PointXYZ twin(0.3f, 0.3f, 0.3f), gone(0.6f, 0.6f, 0.6f);
  for (int i = 0; i < 30; ++i) {
    base.push_back(twin);
    base.push_back(gone);
  }
  // Dropped: a slab (as a crop drops a region), every seventh point, every copy of
  // `gone` and the first ten of `twin`. The rest are renamed into a new cloud, in
  // reverse order, after the added points.
  auto added = uniformCloud(1500, 6); // overlapping the base and beyond it
  for (auto& p : added)
    p.x *= 4.0f;
  pcl::PointCloud<pcl::PointXYZ> now = added;
  std::vector<std::uint32_t> renamed(base.size(), KdTreeIndex::kInvalid);
  int twins_seen = 0;
  for (std::size_t i = base.size(); i-- > 0;) {
    const auto& p = base[i];
    const bool is_twin = p.x == twin.x && p.y == twin.y && p.z == twin.z;
    const bool is_gone = p.x == gone.x && p.y == gone.y && p.z == gone.z;
    const bool drop =
        is_gone || (is_twin && ++twins_seen > 20) || (!is_twin && (p.x < -0.2f || i % 7 == 0));
    if (!drop) {
      renamed[i] = static_cast<std::uint32_t>(now.size());
      now.push_back(p);
    }
  }
  std::vector<std::uint32_t> added_ids(added.size());
  std::iota(added_ids.begin(), added_ids.end(), 0u);
  KdTreeIndex added_tree;
  added_tree.build(added.front().data, added.size(), 4, added_ids.data(), 2);

  const KdTreeIndex merged = KdTreeIndex::merge(buildTree(base, 2), renamed, added_tree);
  EXPECT_EQ(merged.size(), now.size());
  EXPECT_EQ(merged.numParts(), 2u);
  auto queries = clusteredCloud(300, 4);
  queries += uniformCloud(300, 7);
  for (auto& q : queries)
    q.x *= 4.0f;
  queries.push_back(twin);
  queries.push_back(gone);
  expectMatchesBruteForce(merged, now, queries, std::numeric_limits<float>::infinity());
  expectMatchesBruteForce(merged, now, queries, 0.01f);
  expectKnnMatchesBruteForce(merged, now, queries, 20);
  expectRadiusMatchesBruteForce(merged, now, queries, 0.05f);
  float d2 = -1.0f;
  ASSERT_NE(merged.nearest(twin.data, 1.0f, d2), KdTreeIndex::kInvalid);
  EXPECT_EQ(d2, 0.0f); // a kept copy of `twin`, though its duplicate leaf lost its first

  // Merged with nothing dropped, renamed as it was, and nothing added, a tree answers as
  // itself; a base id without an entry in renamed is an error.
  std::vector<std::uint32_t> same(base.size());
  std::iota(same.begin(), same.end(), 0u);
  const KdTreeIndex alone = KdTreeIndex::merge(buildTree(base, 1), same, KdTreeIndex());
  EXPECT_EQ(alone.numParts(), 1u);
  expectMatchesBruteForce(alone, base, queries, std::numeric_limits<float>::infinity());
  same.pop_back();
  EXPECT_THROW(KdTreeIndex::merge(buildTree(base, 1), same, added_tree), std::invalid_argument);
}

TEST(KdTreeIndex, DegenerateClouds)
{
  const auto queries = uniformCloud(200, 6);
  pcl::PointCloud<pcl::PointXYZ> same, line, plane, one, half;
  for (int i = 0; i < 20000; ++i)
    same.push_back(pcl::PointXYZ(0.25f, -0.5f, 0.125f));
  // Half coincident: the first split leaves a 10000-point duplicate leaf beside a range
  // that the parallel build keeps splitting.
  for (int i = 0; i < 20000; ++i)
    half.push_back(i % 2 ? pcl::PointXYZ(-0.5f, 0.0f, 0.0f)
                         : pcl::PointXYZ(0.0001f * static_cast<float>(i), 0.1f, 0.2f));
  for (int i = 0; i < 3000; ++i) {
    line.push_back(pcl::PointXYZ(0.001f * static_cast<float>(i % 1000), 0.3f, -0.2f));
    plane.push_back(pcl::PointXYZ(
        0.02f * static_cast<float>(i % 50), 0.02f * static_cast<float>(i / 50), 0.5f));
  }
  one.push_back(pcl::PointXYZ(0.1f, 0.2f, 0.3f));
  for (const auto* cloud : {&same, &line, &plane, &one, &half}) {
    for (unsigned threads : {1u, 3u}) {
      const auto tree = buildTree(*cloud, threads);
      EXPECT_EQ(tree.size(), cloud->size());
      EXPECT_EQ(tree.numNodes(), buildTree(*cloud, 1).numNodes());
      expectMatchesBruteForce(tree, *cloud, queries, std::numeric_limits<float>::infinity());
      expectMatchesBruteForce(tree, *cloud, queries, 0.3f);
      expectKnnMatchesBruteForce(tree, *cloud, queries, 5);
      expectRadiusMatchesBruteForce(tree, *cloud, queries, 0.4f);
    }
  }
  // 20000 coincident points form one leaf, not a 20000-deep chain of splits.
  EXPECT_EQ(buildTree(same).numNodes(), 1u);
}

TEST(KdTreeIndex, NonFinitePointsAreNeverInsertedOrMatched)
{
  auto cloud = uniformCloud(1000, 7);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  for (std::size_t i = 0; i < cloud.size(); i += 3)
    cloud[i].x = nan;
  cloud[1].z = inf;
  const auto tree = buildTree(cloud);
  EXPECT_EQ(tree.size(), 1000u - 334u - 1u);
  for (std::uint32_t p = 0; p < tree.size(); ++p) {
    EXPECT_NE(tree.id(p) % 3, 0u);
    EXPECT_NE(tree.id(p), 1u);
  }
  expectMatchesBruteForce(
      tree, cloud, uniformCloud(200, 8), std::numeric_limits<float>::infinity());

  // A non-finite query finds nothing.
  float d2;
  const float bad[3] = {nan, 0.0f, 0.0f};
  EXPECT_EQ(tree.nearest(bad, inf, d2), KdTreeIndex::kInvalid);
  std::uint32_t pos;
  EXPECT_EQ(tree.knn(bad, 1, &pos, &d2), 0u);
}

TEST(KdTreeIndex, EmptyAndAllNaNTreesFindNothing)
{
  pcl::PointCloud<pcl::PointXYZ> nan_cloud;
  for (int i = 0; i < 10; ++i)
    nan_cloud.push_back(pcl::PointXYZ(std::numeric_limits<float>::quiet_NaN(), 0, 0));
  for (const auto& cloud : {pcl::PointCloud<pcl::PointXYZ>(), nan_cloud}) {
    const auto tree = buildTree(cloud);
    EXPECT_TRUE(tree.empty());
    const float q[3] = {0, 0, 0};
    float d2;
    EXPECT_EQ(tree.nearest(q, 1e30f, d2), KdTreeIndex::kInvalid);
    std::vector<std::uint32_t> pos;
    std::vector<float> dist;
    EXPECT_EQ(tree.radius(q, 1e30f, pos, dist), 0u);
  }
}

TEST(KdTreeIndex, MaxDistanceIsInclusive)
{
  pcl::PointCloud<pcl::PointXYZ> cloud;
  cloud.push_back(pcl::PointXYZ(3.0f, 0.0f, 0.0f));
  cloud.push_back(pcl::PointXYZ(0.0f, 4.0f, 0.0f));
  const auto tree = buildTree(cloud);
  const float q[3] = {0, 0, 0};
  float d2;
  EXPECT_EQ(tree.id(tree.nearest(q, 9.0f, d2)), 0u);
  EXPECT_EQ(d2, 9.0f);
  EXPECT_EQ(tree.nearest(q, std::nextafter(9.0f, 0.0f), d2), KdTreeIndex::kInvalid);
  EXPECT_EQ(tree.nearest(q, -1.0f, d2), KdTreeIndex::kInvalid);
}

TEST(KdTreeIndex, WarmStartNeverChangesTheAnswer)
{
  const auto cloud = clusteredCloud(20000, 9);
  const auto queries = clusteredCloud(2000, 10);
  const auto tree = buildTree(cloud);
  std::mt19937 rng(11);
  std::uniform_int_distribution<std::uint32_t> any(0,
                                                   static_cast<std::uint32_t>(tree.size() - 1));
  for (const float max_sqr : {std::numeric_limits<float>::infinity(), 0.01f}) {
    for (const auto& q : queries) {
      float cold_d2, warm_d2, good_d2;
      const std::uint32_t cold = tree.nearest(q.data, max_sqr, cold_d2);
      // a random hint (usually far and useless) and the right answer as hint
      const std::uint32_t warm = tree.nearest(q.data, max_sqr, warm_d2, any(rng));
      const std::uint32_t good =
          tree.nearest(q.data, max_sqr, good_d2, cold == KdTreeIndex::kInvalid ? 0 : cold);
      EXPECT_EQ(warm == KdTreeIndex::kInvalid, cold == KdTreeIndex::kInvalid);
      EXPECT_EQ(good == KdTreeIndex::kInvalid, cold == KdTreeIndex::kInvalid);
      if (cold != KdTreeIndex::kInvalid) {
        EXPECT_EQ(warm_d2, cold_d2);
        EXPECT_EQ(good_d2, cold_d2);
        EXPECT_EQ(good, cold);
      }
    }
  }
  // An out-of-range hint is ignored.
  float d2;
  EXPECT_NE(tree.nearest(queries[0].data, 1e30f, d2, 1u << 30), KdTreeIndex::kInvalid);
}

TEST(KdTreeIndex, ThreadCountDoesNotChangeTreeOrResults)
{
  const auto cloud = clusteredCloud(60000, 12);
  const auto queries = uniformCloud(20000, 13);
  const auto reference = buildTree(cloud, 1);
  std::vector<std::uint32_t> ref_pos(queries.size());
  std::vector<float> ref_d2(queries.size());
  reference.nearestBatch(
      queries.front().data, queries.size(), 4, 0.01f, ref_pos.data(), ref_d2.data(), 1);
  for (unsigned threads : {2u, 3u, 4u}) {
    SCOPED_TRACE(threads);
    const auto tree = buildTree(cloud, threads);
    ASSERT_EQ(tree.size(), reference.size());
    ASSERT_EQ(tree.numNodes(), reference.numNodes());
    for (std::uint32_t p = 0; p < tree.size(); ++p)
      ASSERT_EQ(tree.id(p), reference.id(p)) << "leaf order differs at " << p;
    for (auto layout : {pcl_parallel::SlotLayout::kPadded, pcl_parallel::SlotLayout::kPacked}) {
      std::vector<std::uint32_t> pos(queries.size());
      std::vector<float> d2(queries.size());
      tree.nearestBatch(queries.front().data,
                        queries.size(),
                        4,
                        0.01f,
                        pos.data(),
                        d2.data(),
                        threads,
                        layout);
      EXPECT_EQ(pos, ref_pos);
      EXPECT_EQ(d2, ref_d2);
    }
  }
}

TEST(KdTreeIndex, BadArgumentsAreRejected)
{
  const auto cloud = uniformCloud(10, 14);
  KdTreeIndex tree;
  EXPECT_THROW(tree.build(cloud.front().data, cloud.size(), 4, nullptr, 1, 0),
               std::invalid_argument);
  EXPECT_THROW(tree.build(cloud.front().data, cloud.size(), 2), std::invalid_argument);
  EXPECT_THROW(tree.build(nullptr, 5, 3), std::invalid_argument);
  // A thread count that is really a negative int is clamped, not honoured.
  EXPECT_NO_THROW(
      tree.build(cloud.front().data, cloud.size(), 4, nullptr, static_cast<unsigned>(-1)));
  EXPECT_EQ(tree.size(), 10u);
  EXPECT_EQ(pcl_parallel::resolveNumberOfThreads(static_cast<unsigned>(-1)),
            pcl_parallel::kMaxThreads);
  EXPECT_GE(pcl_parallel::resolveNumberOfThreads(0), 1u);
}
