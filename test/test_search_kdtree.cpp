/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pcl_parallel::search::KdTree against PCL's FLANN-backed pcl::search::KdTree.
 */
#include "random_clouds.h"

#include <pcl_parallel/search/kdtree.h>

#include <pcl/features/normal_3d.h>
#include <pcl/search/kdtree.h>

#include <gtest/gtest.h>

using namespace pcl_parallel::test;

namespace {

/** Same neighbour distances as PCL; the same indices unless distances tie. */
void
expectSameNeighbours(const pcl::Indices& ours,
                     const std::vector<float>& ours_d2,
                     const pcl::Indices& pcl_idx,
                     const std::vector<float>& pcl_d2)
{
  ASSERT_EQ(ours.size(), pcl_idx.size());
  ASSERT_EQ(ours_d2.size(), ours.size());
  for (std::size_t j = 0; j < ours.size(); ++j) {
    EXPECT_FLOAT_EQ(ours_d2[j], pcl_d2[j]) << "rank " << j;
    const bool tie = (j > 0 && pcl_d2[j - 1] == pcl_d2[j]) ||
                     (j + 1 < pcl_d2.size() && pcl_d2[j + 1] == pcl_d2[j]);
    if (!tie) {
      EXPECT_EQ(ours[j], pcl_idx[j]) << "rank " << j;
    }
  }
}

template <typename PointT>
pcl::PointCloud<PointT>
toType(const pcl::PointCloud<pcl::PointXYZ>& in)
{
  pcl::PointCloud<PointT> out;
  for (const auto& p : in) {
    PointT q;
    q.x = p.x;
    q.y = p.y;
    q.z = p.z;
    out.push_back(q);
  }
  return out;
}

} // namespace

template <typename PointT>
class SearchKdTreeTyped : public ::testing::Test {};
using PointTypes = ::testing::Types<pcl::PointXYZ, pcl::PointXYZRGB, pcl::PointNormal>;
TYPED_TEST_SUITE(SearchKdTreeTyped, PointTypes);

TYPED_TEST(SearchKdTreeTyped, MatchesPclKdTreeThroughBasePointer)
{
  using PointT = TypeParam;
  auto cloud = toType<PointT>(clusteredCloud(8000, 21)).makeShared();
  (*cloud)[5].x = std::numeric_limits<float>::quiet_NaN(); // never a neighbour
  const auto queries = toType<PointT>(clusteredCloud(300, 22));

  // Use ours only through PCL's interface, as PCL's own algorithms do.
  typename pcl::search::Search<PointT>::Ptr ours(new pcl_parallel::search::KdTree<PointT>);
  pcl::search::KdTree<PointT> reference;
  ours->setInputCloud(cloud);
  reference.setInputCloud(cloud);
  EXPECT_EQ(ours->getInputCloud(), cloud);

  pcl::Indices oi, pi;
  std::vector<float> od, pd;
  for (const auto& q : queries) {
    for (int k : {1, 10}) {
      ASSERT_EQ(ours->nearestKSearch(q, k, oi, od), reference.nearestKSearch(q, k, pi, pd));
      expectSameNeighbours(oi, od, pi, pd);
      for (auto i : oi)
        EXPECT_NE(i, 5);
    }
    ASSERT_EQ(ours->radiusSearch(q, 0.05, oi, od), reference.radiusSearch(q, 0.05, pi, pd));
    expectSameNeighbours(oi, od, pi, pd);
    ASSERT_EQ(ours->radiusSearch(q, 0.05, oi, od, 4),
              reference.radiusSearch(q, 0.05, pi, pd, 4));
    expectSameNeighbours(oi, od, pi, pd);
  }
}

TEST(SearchKdTree, IndicesRestrictTheTreeAndResultsReferToTheCloud)
{
  auto cloud = uniformCloud(4000, 23).makeShared();
  pcl::IndicesPtr every_third(new pcl::Indices);
  for (int i = 0; i < 4000; i += 3)
    every_third->push_back(i);
  pcl_parallel::search::KdTree<pcl::PointXYZ> ours;
  pcl::search::KdTree<pcl::PointXYZ> reference;
  ours.setInputCloud(cloud, every_third);
  reference.setInputCloud(cloud, every_third);
  EXPECT_EQ(ours.getIndices(), every_third);
  pcl::Indices oi, pi;
  std::vector<float> od, pd;
  for (const auto& q : uniformCloud(200, 24)) {
    ours.nearestKSearch(q, 5, oi, od);
    reference.nearestKSearch(q, 5, pi, pd);
    expectSameNeighbours(oi, od, pi, pd);
    for (auto i : oi)
      EXPECT_EQ(i % 3, 0);
  }
  // Out-of-range indices are reported and ignored, not dereferenced.
  pcl::IndicesPtr bad(new pcl::Indices{0, 1, 4000, -2, 7});
  ours.setInputCloud(cloud, bad);
  EXPECT_EQ(ours.index().size(), 3u);
}

// An index built once serves another cloud of the same points (another point type, as
// the pipeline's front end shares a scan's tree): the same neighbours, no rebuild; an
// index that does not fit the cloud is an error.
TEST(SearchKdTree, SharedIndexServesACloudOfTheSamePoints)
{
  auto xyz = uniformCloud(3000, 25).makeShared();
  xyz->push_back(pcl::PointXYZ(NAN, 0, 0)); // not in the tree: counted as not finite
  auto with_normals = toType<pcl::PointNormal>(*xyz).makeShared();
  pcl_parallel::search::KdTree<pcl::PointXYZ> built;
  built.setNumberOfThreads(2);
  built.setInputCloud(xyz);
  pcl_parallel::search::KdTree<pcl::PointNormal> shared, own;
  shared.setInputCloudAndIndex(with_normals, built.sharedIndex());
  own.setInputCloud(with_normals);
  EXPECT_EQ(shared.sharedIndex(), built.sharedIndex()); // the same object, not a copy
  EXPECT_EQ(shared.getInputCloud(), with_normals);
  pcl::Indices si, oi;
  std::vector<float> sd, od;
  for (const auto& q : toType<pcl::PointNormal>(uniformCloud(200, 26))) {
    shared.nearestKSearch(q, 6, si, sd);
    own.nearestKSearch(q, 6, oi, od);
    EXPECT_EQ(si, oi);
    EXPECT_EQ(sd, od);
  }
  auto fewer = toType<pcl::PointNormal>(uniformCloud(2999, 25)).makeShared();
  EXPECT_THROW(shared.setInputCloudAndIndex(fewer, built.sharedIndex()), std::invalid_argument);
  EXPECT_THROW(shared.setInputCloudAndIndex(with_normals, nullptr), std::invalid_argument);
  EXPECT_THROW(shared.setInputCloudAndIndex(nullptr, built.sharedIndex()),
               std::invalid_argument);
  EXPECT_EQ(shared.getInputCloud(), with_normals); // a refused index changes nothing
}

TEST(SearchKdTree, BatchSearchesMatchSingleQueriesForAnyThreadCount)
{
  auto cloud = clusteredCloud(20000, 25).makeShared();
  const auto queries = clusteredCloud(3000, 26);
  pcl::Indices subset;
  for (int i = 0; i < 3000; i += 2)
    subset.push_back(i);
  pcl::search::KdTree<pcl::PointXYZ> reference;
  reference.setInputCloud(cloud);
  std::vector<pcl::Indices> ref_k, ref_r;
  std::vector<std::vector<float>> ref_kd, ref_rd;
  reference.nearestKSearch(queries, subset, 8, ref_k, ref_kd);
  reference.radiusSearch(queries, subset, 0.03, ref_r, ref_rd);
  for (unsigned threads : {1u, 2u, 4u}) {
    pcl_parallel::search::KdTree<pcl::PointXYZ> ours;
    ours.setNumberOfThreads(threads);
    ours.setInputCloud(cloud);
    std::vector<pcl::Indices> k_idx, r_idx;
    std::vector<std::vector<float>> k_d2, r_d2;
    ours.nearestKSearch(queries, subset, 8, k_idx, k_d2);
    ours.radiusSearch(queries, subset, 0.03, r_idx, r_d2);
    ASSERT_EQ(k_idx.size(), subset.size());
    ASSERT_EQ(r_idx.size(), subset.size());
    for (std::size_t i = 0; i < subset.size(); ++i) {
      expectSameNeighbours(k_idx[i], k_d2[i], ref_k[i], ref_kd[i]);
      expectSameNeighbours(r_idx[i], r_d2[i], ref_r[i], ref_rd[i]);
    }
  }
}

TEST(SearchKdTree, UnsortedRadiusSearchReturnsTheSameSet)
{
  auto cloud = uniformCloud(5000, 27).makeShared();
  pcl_parallel::search::KdTree<pcl::PointXYZ> ours(false);
  ours.setInputCloud(cloud);
  pcl::search::KdTree<pcl::PointXYZ> reference;
  reference.setInputCloud(cloud);
  pcl::Indices oi, pi;
  std::vector<float> od, pd;
  for (const auto& q : uniformCloud(50, 28)) {
    ours.radiusSearch(q, 0.2, oi, od);
    reference.radiusSearch(q, 0.2, pi, pd);
    std::sort(oi.begin(), oi.end());
    std::sort(pi.begin(), pi.end());
    EXPECT_EQ(oi, pi);
  }
}

TEST(SearchKdTree, EmptyAllNaNAndNullCloudsFindNothing)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr nan_cloud(new pcl::PointCloud<pcl::PointXYZ>);
  for (int i = 0; i < 5; ++i)
    nan_cloud->push_back(pcl::PointXYZ(std::numeric_limits<float>::quiet_NaN(), 0, 0));
  pcl_parallel::search::KdTree<pcl::PointXYZ> tree;
  pcl::Indices idx;
  std::vector<float> d2;
  for (const auto& cloud :
       {pcl::PointCloud<pcl::PointXYZ>::Ptr(new pcl::PointCloud<pcl::PointXYZ>),
        nan_cloud,
        pcl::PointCloud<pcl::PointXYZ>::Ptr()}) {
    tree.setInputCloud(cloud);
    EXPECT_EQ(tree.nearestKSearch(pcl::PointXYZ(0, 0, 0), 3, idx, d2), 0);
    EXPECT_TRUE(idx.empty());
    EXPECT_EQ(tree.radiusSearch(pcl::PointXYZ(0, 0, 0), 1e9, idx, d2), 0);
  }
}

TEST(SearchKdTree, DropsIntoPclNormalEstimation)
{
  auto cloud = clusteredCloud(3000, 29).makeShared();
  pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
  ne.setInputCloud(cloud);
  ne.setKSearch(12);
  pcl::PointCloud<pcl::Normal> with_pcl, with_ours;
  ne.setSearchMethod(
      pcl::search::KdTree<pcl::PointXYZ>::Ptr(new pcl::search::KdTree<pcl::PointXYZ>));
  ne.compute(with_pcl);
  ne.setSearchMethod(pcl_parallel::search::KdTree<pcl::PointXYZ>::Ptr(
      new pcl_parallel::search::KdTree<pcl::PointXYZ>));
  ne.compute(with_ours);
  ASSERT_EQ(with_pcl.size(), with_ours.size());
  std::size_t same = 0;
  for (std::size_t i = 0; i < with_pcl.size(); ++i)
    same +=
        std::abs(with_pcl[i].getNormalVector3fMap().dot(with_ours[i].getNormalVector3fMap())) >
        1.0f - 1e-4f;
  // Neighbourhoods can differ only where the 12th and 13th neighbour tie.
  EXPECT_GE(same, with_pcl.size() - 2);
}
