/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * ParallelCorrespondenceEstimation against PCL's expected tables, PCL's own estimator
 * and brute force.
 */
#include "random_clouds.h"
#include "test_data.h"

#include <pcl_parallel/registration/correspondence_estimation.h>

#include <pcl/io/pcd_io.h>
#include <pcl/registration/correspondence_estimation.h>
#include <pcl/registration/icp.h>

#include <fstream>
#include <gtest/gtest.h>
#include <sstream>

using namespace pcl_parallel::test;
using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Estimation =
    pcl_parallel::registration::ParallelCorrespondenceEstimation<pcl::PointXYZ, pcl::PointXYZ>;

namespace {

std::vector<std::pair<int, int>>
readPairs(const std::string& path)
{
  std::ifstream in(path);
  std::string line;
  std::getline(in, line); // header
  std::vector<std::pair<int, int>> pairs;
  while (std::getline(in, line)) {
    std::replace(line.begin(), line.end(), ',', ' ');
    std::istringstream ss(line);
    int q, m;
    if (ss >> q >> m)
      pairs.emplace_back(q, m);
  }
  return pairs;
}

std::vector<std::pair<int, int>>
pairsOf(const pcl::Correspondences& c)
{
  std::vector<std::pair<int, int>> out;
  for (const auto& x : c)
    out.emplace_back(x.index_query, x.index_match);
  return out;
}

Cloud::Ptr
loadPcd(const std::string& path)
{
  Cloud::Ptr cloud(new Cloud);
  if (pcl::io::loadPCDFile(path, *cloud) != 0)
    ADD_FAILURE() << "cannot read " << path;
  return cloud;
}

/** Same correspondences as PCL's: same pairs in the same order and the same (squared)
 *  distances, except that equidistant matches may pick another target point. */
void
expectSameAsPcl(const pcl::Correspondences& ours, const pcl::Correspondences& reference)
{
  ASSERT_EQ(ours.size(), reference.size());
  for (std::size_t i = 0; i < ours.size(); ++i) {
    EXPECT_EQ(ours[i].index_query, reference[i].index_query) << i;
    EXPECT_EQ(ours[i].distance, reference[i].distance) << i;
    EXPECT_EQ(ours[i].index_match, reference[i].index_match) << i;
  }
}

} // namespace

TEST(ParallelCorrespondenceEstimation, ReproducesPclTablesOnBun0Bun4)
{
  PCL_PARALLEL_REQUIRE_DATA(bun0, "pcl_test/bun0.pcd");
  PCL_PARALLEL_REQUIRE_DATA(bun4, "pcl_test/bun4.pcd");
  PCL_PARALLEL_REQUIRE_DATA(original, "pcl_test/expected/correspondences_original.csv");
  PCL_PARALLEL_REQUIRE_DATA(reciprocal, "pcl_test/expected/correspondences_reciprocal.csv");
  Estimation est;
  est.setInputSource(loadPcd(bun0));
  est.setInputTarget(loadPcd(bun4));
  for (unsigned threads : {1u, 2u}) {
    est.setNumberOfThreads(threads);
    pcl::Correspondences corr;
    est.determineCorrespondences(corr);
    ASSERT_EQ(corr.size(), 397u);
    EXPECT_EQ(pairsOf(corr), readPairs(original));
    est.determineReciprocalCorrespondences(corr);
    ASSERT_EQ(corr.size(), 53u);
    EXPECT_EQ(pairsOf(corr), readPairs(reciprocal));
  }
}

TEST(ParallelCorrespondenceEstimation, EqualsPclEstimatorOnRandomClouds)
{
  const auto source = clusteredCloud(6000, 31).makeShared();
  const auto target = jittered(clusteredCloud(7000, 31), 0.01f, 32).makeShared();
  pcl::registration::CorrespondenceEstimation<pcl::PointXYZ, pcl::PointXYZ> reference;
  reference.setInputSource(source);
  reference.setInputTarget(target);
  Estimation ours;
  ours.setInputSource(source);
  ours.setInputTarget(target);
  for (double max_distance : {std::numeric_limits<double>::max(), 0.05, 0.01}) {
    SCOPED_TRACE(max_distance);
    pcl::Correspondences a, b;
    ours.determineCorrespondences(a, max_distance);
    reference.determineCorrespondences(b, max_distance);
    expectSameAsPcl(a, b);
    EXPECT_GT(a.size(), 1000u);
    ours.determineReciprocalCorrespondences(a, max_distance);
    reference.determineReciprocalCorrespondences(b, max_distance);
    expectSameAsPcl(a, b);
    EXPECT_GT(a.size(), 100u);
  }
}

TEST(ParallelCorrespondenceEstimation, EqualsBruteForceForAnyThreadCount)
{
  auto source = uniformCloud(3000, 33).makeShared();
  const auto target = clusteredCloud(3000, 34).makeShared();
  (*source)[10].y = std::numeric_limits<float>::quiet_NaN(); // gets no correspondence
  const double max_distance = 0.4;
  pcl::Correspondences expected;
  for (std::size_t i = 0; i < source->size(); ++i) {
    const auto [m, d2] =
        bruteNearest((*source)[i], *target, static_cast<float>(max_distance * max_distance));
    if (m >= 0)
      expected.emplace_back(static_cast<int>(i), m, d2);
  }
  ASSERT_GT(expected.size(), 100u);
  ASSERT_LT(expected.size(), source->size() - 100);
  for (unsigned threads : {1u, 2u, 3u, 4u}) {
    Estimation est;
    est.setNumberOfThreads(threads);
    est.setInputSource(source);
    est.setInputTarget(target);
    pcl::Correspondences corr;
    est.determineCorrespondences(corr, max_distance);
    expectSameAsPcl(corr, expected);
  }
}

TEST(ParallelCorrespondenceEstimation, HonoursSourceAndTargetIndices)
{
  const auto source = uniformCloud(2000, 35).makeShared();
  const auto target = uniformCloud(2000, 36).makeShared();
  pcl::IndicesPtr src_idx(new pcl::Indices), tgt_idx(new pcl::Indices);
  for (int i = 0; i < 2000; i += 2)
    src_idx->push_back(i);
  for (int i = 1; i < 2000; i += 3)
    tgt_idx->push_back(i);
  pcl::registration::CorrespondenceEstimation<pcl::PointXYZ, pcl::PointXYZ> reference;
  Estimation ours;
  for (auto* est : std::vector<
           pcl::registration::CorrespondenceEstimationBase<pcl::PointXYZ, pcl::PointXYZ>*>{
           &reference, &ours}) {
    est->setInputSource(source);
    est->setInputTarget(target);
    est->setIndicesSource(src_idx);
    est->setIndicesTarget(tgt_idx);
  }
  pcl::Correspondences a, b;
  ours.determineCorrespondences(a, 0.2);
  reference.determineCorrespondences(b, 0.2);
  expectSameAsPcl(a, b);
  for (const auto& c : a) {
    EXPECT_EQ(c.index_query % 2, 0);
    EXPECT_EQ(c.index_match % 3, 1);
  }
  ours.determineReciprocalCorrespondences(a, 0.2);
  reference.determineReciprocalCorrespondences(b, 0.2);
  expectSameAsPcl(a, b);
}

TEST(ParallelCorrespondenceEstimation, MixedPointTypes)
{
  const auto source = clusteredCloud(3000, 37).makeShared();
  Cloud::Ptr target_xyz(new Cloud); // the source, shifted a little and thinned
  for (std::size_t i = 0; i < source->size(); i += 2) {
    const auto& p = (*source)[i];
    target_xyz->push_back(pcl::PointXYZ(p.x + 0.004f, p.y - 0.002f, p.z + 0.001f));
  }
  pcl::PointCloud<pcl::PointNormal>::Ptr target(new pcl::PointCloud<pcl::PointNormal>);
  pcl::copyPointCloud(*target_xyz, *target);
  pcl_parallel::registration::ParallelCorrespondenceEstimation<pcl::PointXYZ, pcl::PointNormal>
      mixed;
  mixed.setInputSource(source);
  mixed.setInputTarget(target);
  Estimation same;
  same.setInputSource(source);
  same.setInputTarget(target_xyz);
  pcl::Correspondences a, b;
  mixed.determineCorrespondences(a, 0.1);
  same.determineCorrespondences(b, 0.1);
  expectSameAsPcl(a, b);
  mixed.determineReciprocalCorrespondences(a, 0.1);
  same.determineReciprocalCorrespondences(b, 0.1);
  expectSameAsPcl(a, b);
  EXPECT_FALSE(a.empty());
}

TEST(ParallelCorrespondenceEstimation, SearchMethodTargetSemantics)
{
  const auto source = uniformCloud(500, 39).makeShared();
  const auto cloud_a = uniformCloud(800, 40).makeShared();
  const auto cloud_b = uniformCloud(800, 41).makeShared();
  auto expectMatchesOf = [&](const pcl::Correspondences& corr, const Cloud& cloud) {
    ASSERT_EQ(corr.size(), source->size());
    for (const auto& c : corr)
      EXPECT_EQ(c.index_match, bruteNearest((*source)[c.index_query], cloud).first);
  };
  pcl::Correspondences corr;

  // force_no_recompute: the given tree is trusted as built, even on another cloud.
  pcl_parallel::search::KdTree<pcl::PointXYZ>::Ptr tree_a(
      new pcl_parallel::search::KdTree<pcl::PointXYZ>);
  tree_a->setInputCloud(cloud_a);
  Estimation est;
  est.setInputSource(source);
  est.setInputTarget(cloud_b);
  est.setSearchMethodTarget(tree_a, true);
  est.determineCorrespondences(corr);
  expectMatchesOf(corr, *cloud_a);

  // Without it, the tree is rebuilt on the target.
  est.setSearchMethodTarget(tree_a, false);
  est.determineCorrespondences(corr);
  expectMatchesOf(corr, *cloud_b);
  EXPECT_EQ(tree_a->getInputCloud(), cloud_b);

  // A plain PCL tree is left alone; the estimator searches a private tree of its own.
  pcl::search::KdTree<pcl::PointXYZ>::Ptr flann(new pcl::search::KdTree<pcl::PointXYZ>);
  flann->setInputCloud(cloud_a);
  est.setInputTarget(cloud_b);
  est.setSearchMethodTarget(flann);
  est.determineCorrespondences(corr);
  expectMatchesOf(corr, *cloud_b);
  EXPECT_EQ(flann->getInputCloud(), cloud_a);

  // A never-built tree with force_no_recompute is an error, not a crash.
  est.setSearchMethodTarget(pcl_parallel::search::KdTree<pcl::PointXYZ>::Ptr(
                                new pcl_parallel::search::KdTree<pcl::PointXYZ>),
                            true);
  est.determineCorrespondences(corr);
  EXPECT_TRUE(corr.empty());
}

TEST(ParallelCorrespondenceEstimation, BadInputGivesNoCorrespondences)
{
  const auto good = uniformCloud(100, 42).makeShared();
  Cloud::Ptr empty(new Cloud), nan_cloud(new Cloud);
  for (int i = 0; i < 50; ++i)
    nan_cloud->push_back(pcl::PointXYZ(std::numeric_limits<float>::quiet_NaN(), 1, 2));
  pcl::Correspondences corr{pcl::Correspondence(1, 2, 3.0f)}; // stale content is cleared
  Estimation est;
  est.determineCorrespondences(corr); // nothing set at all
  EXPECT_TRUE(corr.empty());
  for (const auto& [source, target] : {std::make_pair(good, empty),
                                       std::make_pair(good, nan_cloud),
                                       std::make_pair(empty, good),
                                       std::make_pair(nan_cloud, good)}) {
    est.setInputSource(source);
    est.setInputTarget(target);
    corr.assign(3, pcl::Correspondence(1, 2, 3.0f));
    est.determineCorrespondences(corr);
    EXPECT_TRUE(corr.empty());
    est.determineReciprocalCorrespondences(corr);
    EXPECT_TRUE(corr.empty());
  }
}

TEST(ParallelCorrespondenceEstimation, PlugsIntoPclIterativeClosestPoint)
{
  PCL_PARALLEL_REQUIRE_DATA(bun0, "pcl_test/bun0.pcd");
  PCL_PARALLEL_REQUIRE_DATA(bun4, "pcl_test/bun4.pcd");
  const auto source = loadPcd(bun0);
  const auto target = loadPcd(bun4);
  auto run = [&](bool ours) {
    pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
    icp.setInputSource(source);
    icp.setInputTarget(target);
    icp.setMaximumIterations(50);
    icp.setMaxCorrespondenceDistance(0.05);
    icp.setTransformationEpsilon(1e-8);
    if (ours)
      icp.setCorrespondenceEstimation(Estimation::Ptr(new Estimation));
    Cloud out;
    icp.align(out);
    EXPECT_TRUE(icp.hasConverged());
    return Eigen::Matrix4f(icp.getFinalTransformation());
  };
  const Eigen::Matrix4f with_pcl = run(false);
  const Eigen::Matrix4f with_ours = run(true);
  // Identical correspondences each iteration give an identical transform.
  EXPECT_TRUE(with_ours.isApprox(with_pcl, 1e-6f)) << with_ours << "\nvs PCL\n" << with_pcl;
  EXPECT_NEAR(with_ours(0, 0), 0.8806f, 2e-3f); // PCL 1.13's published result (data README)
  EXPECT_NEAR(with_ours(0, 2), -0.4724f, 2e-3f);
}
