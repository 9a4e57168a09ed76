/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The bad-input table of docs/robustness.md (issue 11): every row not covered by a test
 * of its own module is here. Each case asserts what happens (the documented state or
 * exception), that nothing non-finite comes out, and, where an answer exists, the answer.
 */
#include "random_clouds.h"

#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/registration/icp.h>
#include <pcl_parallel/registration/lum.h>
#include <pcl_parallel/sim/simulated_scans.h>

#include <pcl/common/transforms.h>
#include <pcl/console/print.h>

#include <cmath>
#include <cstdint>
#include <gtest/gtest.h>
#include <limits>
#include <random>

namespace {

using pcl::PointCloud;
using pcl::PointXYZ;
using PIcp = pcl_parallel::registration::ParallelIterativeClosestPoint<PointXYZ, PointXYZ>;
using State = pcl::registration::DefaultConvergenceCriteria<float>::ConvergenceState;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

class Robustness : public ::testing::Test {
protected:
  void
  SetUp() override
  {
    pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); // the cases print by design
  }
};

PointCloud<PointXYZ>::Ptr
shifted(const PointCloud<PointXYZ>& cloud, float dx, float dy, float dz)
{
  PointCloud<PointXYZ>::Ptr out(new PointCloud<PointXYZ>(cloud));
  for (auto& p : *out) {
    p.x += dx;
    p.y += dy;
    p.z += dz;
  }
  return out;
}

struct IcpRun {
  bool converged;
  State state;
  Eigen::Matrix4f final;
  PointCloud<PointXYZ> out;
};

IcpRun
runIcp(const PointCloud<PointXYZ>::Ptr& src,
       const PointCloud<PointXYZ>::Ptr& tgt,
       double max_distance,
       unsigned threads = 2,
       const Eigen::Matrix4f& guess = Eigen::Matrix4f::Identity())
{
  PIcp icp;
  icp.setNumberOfThreads(threads);
  icp.setMaxCorrespondenceDistance(max_distance);
  icp.setMaximumIterations(30);
  icp.setTransformationEpsilon(1e-10);
  icp.setInputSource(src);
  icp.setInputTarget(tgt);
  IcpRun r;
  EXPECT_NO_THROW(icp.align(r.out, guess));
  r.converged = icp.hasConverged();
  r.state = icp.getConvergeCriteria()->getConvergenceState();
  r.final = icp.getFinalTransformation();
  EXPECT_TRUE(r.final.allFinite()) << r.final;
  EXPECT_EQ(r.out.size(), src->size());
  for (std::size_t i = 0; i < r.out.size(); ++i) {
    const auto& p = r.out[i];
    if (std::isfinite((*src)[i].x)) { // NaN in, NaN out; finite in, finite out
      EXPECT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) << i;
    }
  }
  return r;
}

/** The documented "nothing to align" outcome: not converged, no correspondences, the
 *  guess returned unchanged. */
void
expectNoCorrespondences(const IcpRun& r, const Eigen::Matrix4f& guess)
{
  EXPECT_FALSE(r.converged);
  EXPECT_EQ(r.state, State::CONVERGENCE_CRITERIA_NO_CORRESPONDENCES);
  EXPECT_EQ(r.final, guess);
}

// One point each: fewer than 3 correspondences.
TEST_F(Robustness, IcpOnePoint)
{
  PointCloud<PointXYZ>::Ptr a(new PointCloud<PointXYZ>), b(new PointCloud<PointXYZ>);
  a->push_back(PointXYZ(1, 2, 3));
  b->push_back(PointXYZ(1.1f, 2, 3));
  expectNoCorrespondences(runIcp(a, b, 1.0), Eigen::Matrix4f::Identity());
}

// All points coincide (the correlation matrix is zero, the rotation undetermined): the
// translation still takes the source point onto the target point.
TEST_F(Robustness, IcpIdenticalPoints)
{
  PointCloud<PointXYZ>::Ptr a(new PointCloud<PointXYZ>), b(new PointCloud<PointXYZ>);
  for (int i = 0; i < 100; ++i) {
    a->push_back(PointXYZ(1, 2, 3));
    b->push_back(PointXYZ(1.25f, 2, 3));
  }
  const IcpRun r = runIcp(a, b, 1.0);
  EXPECT_TRUE(r.converged);
  for (const auto& p : r.out)
    EXPECT_LT((p.getVector3fMap() - Eigen::Vector3f(1.25f, 2, 3)).norm(), 1e-5f);
}

// Source = target (the same cloud object): the identity, converged.
TEST_F(Robustness, IcpSourceEqualsTarget)
{
  const auto cloud = pcl_parallel::test::uniformCloud(2000, 5).makeShared();
  const IcpRun r = runIcp(cloud, cloud, 0.1);
  EXPECT_TRUE(r.converged);
  EXPECT_TRUE(r.final.isApprox(Eigen::Matrix4f::Identity(), 1e-6f)) << r.final;
}

// 10^6 units from the origin, where float spacing is 1/16: the moments are taken about a
// reference point in double, so the known 0.5 shift is recovered to float resolution.
TEST_F(Robustness, IcpFarFromTheOrigin)
{
  auto base = pcl_parallel::test::uniformCloud(3000, 6);
  for (auto& p : base) // 100 m cube at (1e6, 1e6, 1e6): points ~7 m apart
    p.getVector3fMap() = p.getVector3fMap() * 50.0f + Eigen::Vector3f::Constant(1e6f);
  const auto src = base.makeShared();
  const auto tgt = shifted(base, 0.5f, -0.25f, 0.0f); // exact: multiples of 1/16
  const IcpRun r = runIcp(src, tgt, 2.0);
  EXPECT_TRUE(r.converged);
  double worst = 0.0;
  for (std::size_t i = 0; i < src->size(); ++i)
    worst = std::max<double>(worst,
                             (r.out[i].getVector3fMap() - (*tgt)[i].getVector3fMap()).norm());
  // One float ulp per axis at 1e6 is 0.0625: sqrt(3) ulp plus the output's rounding.
  EXPECT_LT(worst, 0.125) << r.final;
}

// Target 100 m away, beyond the correspondence distance: nothing to pair.
TEST_F(Robustness, IcpNoOverlap)
{
  const auto cloud = pcl_parallel::test::uniformCloud(500, 7);
  expectNoCorrespondences(runIcp(cloud.makeShared(), shifted(cloud, 100, 0, 0), 1.0),
                          Eigen::Matrix4f::Identity());
}

// Max correspondence distance 0, negative or NaN: nothing pairs (0: only exact
// coincidences, here none), never a NaN transform.
TEST_F(Robustness, IcpMaxDistanceZeroNegativeNaN)
{
  const auto cloud = pcl_parallel::test::uniformCloud(500, 8);
  const auto tgt = shifted(cloud, 0.01f, 0, 0);
  for (double d : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN()})
    expectNoCorrespondences(runIcp(cloud.makeShared(), tgt, d), Eigen::Matrix4f::Identity());
  // 0 with exact coincidences: those pair, and the identity is the answer.
  const IcpRun same = runIcp(cloud.makeShared(), cloud.makeShared(), 0.0);
  EXPECT_TRUE(same.converged);
  EXPECT_LT((same.final - Eigen::Matrix4f::Identity()).norm(), 1e-6f) << same.final;
}

// Thread counts 0 (all cores), "negative" (an int -1 passed as unsigned) and huge: clamped
// to [1, kMaxThreads], and the result is bit-identical to one thread.
TEST_F(Robustness, IcpThreadCountsZeroNegativeHuge)
{
  const auto cloud = pcl_parallel::test::uniformCloud(3000, 9);
  Eigen::Matrix4f motion = Eigen::Matrix4f::Identity();
  motion.topLeftCorner<3, 3>() =
      Eigen::AngleAxisf(0.05f, Eigen::Vector3f(1, 2, 3).normalized()).toRotationMatrix();
  motion(0, 3) = 0.02f;
  PointCloud<PointXYZ>::Ptr tgt(new PointCloud<PointXYZ>);
  pcl::transformPointCloud(cloud, *tgt, motion);
  const IcpRun one = runIcp(cloud.makeShared(), tgt, 0.2, 1);
  EXPECT_TRUE(one.converged);
  for (unsigned threads : {0u, static_cast<unsigned>(-1), 1000000u}) {
    const IcpRun r = runIcp(cloud.makeShared(), tgt, 0.2, threads);
    EXPECT_EQ(r.final, one.final) << threads;
  }
  EXPECT_EQ(pcl_parallel::resolveNumberOfThreads(1000000u), pcl_parallel::kMaxThreads);
}

// pLUM on bad clouds: an all-NaN scan (its links find no pairs and are dropped; compute()
// stops with the start poses), a one-point scan (fewer pairs than the minimum), an empty
// scan (std::invalid_argument), and thread counts 0 / "negative" / huge.
TEST_F(Robustness, LumBadCloudsAndThreadCounts)
{
  using Lum = pcl_parallel::ParallelLUM<PointXYZ>;
  const auto good = pcl_parallel::test::uniformCloud(2000, 10).makeShared();
  PointCloud<PointXYZ>::Ptr nan(new PointCloud<PointXYZ>), one(new PointCloud<PointXYZ>);
  for (int i = 0; i < 100; ++i)
    nan->push_back(PointXYZ(kNaN, kNaN, kNaN));
  nan->is_dense = false;
  one->push_back(PointXYZ(0, 0, 0));
  Eigen::Matrix4d start = Eigen::Matrix4d::Identity();
  start(0, 3) = 0.01;
  for (const auto& bad : {nan, one}) {
    Lum lum;
    lum.addPointCloud(good, Eigen::Matrix4f::Identity());
    lum.addPointCloud(bad, Eigen::Matrix4f(start.cast<float>()));
    lum.addLink(0, 1);
    lum.setCorrespondenceDistance(0.1);
    EXPECT_NO_THROW(lum.compute());
    EXPECT_EQ(lum.getNumDroppedLinks(), 1u);
    // The start pose went in as float (addPointCloud's Matrix4f) and is kept as given.
    EXPECT_EQ(lum.getPoseMatrix(1), Eigen::Matrix4d(start.cast<float>().cast<double>()));
  }
  Lum empty;
  empty.addPointCloud(good, Eigen::Matrix4f::Identity());
  empty.addPointCloud(PointCloud<PointXYZ>::Ptr(new PointCloud<PointXYZ>),
                      Eigen::Matrix4f::Identity());
  empty.addLink(0, 1);
  empty.setCorrespondenceDistance(0.1);
  EXPECT_THROW(empty.compute(), std::invalid_argument);
  EXPECT_THROW(empty.setCorrespondenceDistance(std::numeric_limits<double>::quiet_NaN()),
               std::invalid_argument);

  Eigen::Matrix4d result[2];
  int k = 0;
  for (unsigned threads : {1u, 0u, static_cast<unsigned>(-1), 1000000u}) {
    Lum lum;
    lum.setNumberOfThreads(threads);
    lum.addPointCloud(good, Eigen::Matrix4f::Identity());
    lum.addPointCloud(good, Eigen::Matrix4f(start.cast<float>()));
    lum.addLink(0, 1);
    lum.setCorrespondenceDistance(0.1);
    lum.setMaxIterations(10);
    lum.compute();
    result[k == 0 ? 0 : 1] = lum.getPoseMatrix(1);
    const double offset = result[0].topRightCorner<3, 1>().norm();
    if (k++ == 0) {
      EXPECT_LT(offset, 1e-6); // back onto scan 0
    }
    else {
      EXPECT_EQ(result[1], result[0]) << threads;
    }
  }
}

// Far from the origin the squared distances are large and close together (1e4 offset,
// 1 mm spacing: squares ~1e8 with an ulp of 8, differences ~1e-6), where an incrementally
// updated cell bound cancels; the search must still equal brute force with the same
// float distances (docs/design.md, "Why pruning is exact").
TEST_F(Robustness, KdTreeExactFarFromTheOrigin)
{
  auto cloud = pcl_parallel::test::uniformCloud(20000, 11);
  for (auto& p : cloud)
    p.getVector3fMap() = p.getVector3fMap() * 0.05f + Eigen::Vector3f(1e4f, -1e4f, 1e4f);
  pcl_parallel::KdTreeIndex tree;
  tree.build(cloud.front().data, cloud.size(), 4, nullptr, 2, 1);
  std::mt19937 rng(12);
  std::uniform_real_distribution<float> u(-0.06f, 0.06f);
  for (int i = 0; i < 5000; ++i) {
    const PointXYZ q(1e4f + u(rng), -1e4f + u(rng), 1e4f + u(rng));
    float d2 = 0.0f;
    const std::uint32_t pos = tree.nearest(q.data, std::numeric_limits<float>::infinity(), d2);
    const auto [index, brute_d2] = pcl_parallel::test::bruteNearest(q, cloud);
    ASSERT_NE(pos, pcl_parallel::KdTreeIndex::kInvalid);
    ASSERT_EQ(d2, brute_d2) << "query " << i << ": tree id " << tree.id(pos) << ", brute "
                            << index;
  }
}

// Limits: the k-d tree's uint32 indices (points and nodes) and the simulator's scan count
// are checked before a cast could wrap.
TEST_F(Robustness, IndexLimitsAreCheckedNotWrapped)
{
  using pcl_parallel::KdTreeIndex;
  EXPECT_NO_THROW(KdTreeIndex::checkCapacity(1000, 1));
  EXPECT_NO_THROW(KdTreeIndex::checkCapacity(std::size_t{1} << 31, 12));
  // 2^31 points in buckets of 1 need ~2^32 nodes; 2^32 points overflow the positions.
  EXPECT_THROW(KdTreeIndex::checkCapacity(std::size_t{1} << 31, 1), std::invalid_argument);
  EXPECT_THROW(KdTreeIndex::checkCapacity(std::size_t{1} << 32, 12), std::invalid_argument);
  EXPECT_THROW(KdTreeIndex::checkCapacity(10, 0), std::invalid_argument);

  pcl_parallel::sim::SimulationParameters p;
  p.step_length = 1e-300; // laps * perimeter / step overflows int
  EXPECT_THROW(pcl_parallel::sim::simulateScanSet(p), std::invalid_argument);
  p.step_length = std::numeric_limits<double>::denorm_min();
  EXPECT_THROW(pcl_parallel::sim::simulateScanSet(p), std::invalid_argument);
}

} // namespace
