/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The front end's stages one by one (slam/motion_model.h, deskewer.h, reducer.h,
 * matcher.h, pose_guess.h) and their parameters (parameters.h), each against what it must
 * equal: the automatic lengths' rules, exact poses for the motion model, the voxel filters
 * for the reducer, a known step for the matcher and the pose guess; what a run's input and
 * result suggest (findings.h). test_slam runs them together through the Pipeline.
 */
#include "random_clouds.h"

#include <pcl_parallel/filters/voxel_grid.h>
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/slam/deskewer.h>
#include <pcl_parallel/slam/findings.h>
#include <pcl_parallel/slam/loop_closure.h>
#include <pcl_parallel/slam/matcher.h>
#include <pcl_parallel/slam/motion_model.h>
#include <pcl_parallel/slam/pose_guess.h>
#include <pcl_parallel/slam/preprocess.h>
#include <pcl_parallel/slam/reducer.h>
#include <pcl_parallel/slam/sweep_path.h>

#include <pcl/common/transforms.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <gtest/gtest.h>
#include <limits>
#include <optional>
#include <stdexcept>

namespace {

using namespace pcl_parallel;
using slam::Cloud;
using slam::Pose;

constexpr double kDeg = M_PI / 180.0;

Pose
makePose(double yaw, double x, double y, double z = 0.0)
{
  Pose p = Pose::Identity();
  p.topLeftCorner<3, 3>() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  p.topRightCorner<3, 1>() = Eigen::Vector3d(x, y, z);
  return p;
}

/** The test room (random_clouds.h) around a scanner near its middle. */
Cloud
room(std::uint32_t seed = 1)
{
  Cloud cloud = test::roomCloud(20000, seed, 0.002f);
  for (auto& p : cloud)
    p.getVector3fMap() -= Eigen::Vector3f(2.2f, 1.4f, 1.2f);
  return cloud;
}

/** `world` as a scanner at `pose` sees it. */
Cloud
seenFrom(const Cloud& world, const Pose& pose)
{
  Cloud out;
  pcl::transformPointCloud(world, out, Pose(pose.inverse()));
  return out;
}

/** The pipeline's automatic lengths for 5 cm voxels in a room of 5 m median range. */
slam::Parameters
roomParameters(slam::MatchTarget target)
{
  slam::Parameters p;
  p.matcher.target = target;
  p.reduction.voxel_size = 0.05;
  p.matcher.map_distance = 10.0;
  p.matcher.max_correspondence_distance = 0.5;
  p.matcher.final_correspondence_distance = 0.1;
  return slam::resolve(p, 5.0);
}

// Every automatic length follows from the median range r (docs/design.md, "Automatic
// scale"): voxel r / 20, gates 10 and 2 voxels, map voxel 2, loops within r; set lengths
// and the range crop are kept, and the loop pICP follows the matcher's.
TEST(Parameters, ResolveSetsTheAutomaticLengthsFromTheMedianRange)
{
  const slam::Parameters automatic = slam::resolve(slam::Parameters(), 8.0);
  EXPECT_TRUE(slam::isResolved(automatic));
  EXPECT_FALSE(slam::isResolved(slam::Parameters()));
  EXPECT_DOUBLE_EQ(automatic.median_range, 8.0);
  EXPECT_DOUBLE_EQ(automatic.reduction.voxel_size, 0.4);
  EXPECT_DOUBLE_EQ(automatic.reduction.source_voxel_size, 1.2);
  EXPECT_DOUBLE_EQ(automatic.matcher.map_voxel_size, 0.8);
  EXPECT_DOUBLE_EQ(automatic.matcher.map_distance, 40.0); // unbounded range: 5 r
  EXPECT_DOUBLE_EQ(automatic.matcher.max_correspondence_distance, 4.0);
  EXPECT_DOUBLE_EQ(automatic.matcher.final_correspondence_distance, 0.8);
  EXPECT_DOUBLE_EQ(automatic.loops.distance, 8.0);
  EXPECT_DOUBLE_EQ(automatic.loops.overlap_distance, 0.8);
  EXPECT_DOUBLE_EQ(automatic.loops.icp_distance, 4.0);
  EXPECT_EQ(automatic.loops.icp_iterations, 50);
  EXPECT_DOUBLE_EQ(automatic.loops.lum_distance, 4.0);
  EXPECT_DOUBLE_EQ(automatic.loops.lum_final_distance, 0.8);
  EXPECT_DOUBLE_EQ(automatic.loops.lum_epsilon, 0.004);

  slam::Parameters p;
  p.reduction.voxel_size = 0.1;
  p.reduction.max_range = 25.0;
  p.matcher.max_correspondence_distance = 0.3;
  p.matcher.final_correspondence_distance = 0.5; // wider than the gate: capped by it
  p.matcher.max_iterations = 80;
  p.loops.distance = 3.0;
  p.median_range = 6.0; // the user's scale wins over the scans'
  const slam::Parameters q = slam::resolve(p, 8.0);
  EXPECT_DOUBLE_EQ(q.median_range, 6.0);
  EXPECT_DOUBLE_EQ(q.reduction.voxel_size, 0.1);
  EXPECT_DOUBLE_EQ(q.matcher.map_distance, 25.0);
  EXPECT_DOUBLE_EQ(q.matcher.max_correspondence_distance, 0.3);
  EXPECT_DOUBLE_EQ(q.matcher.final_correspondence_distance, 0.3);
  EXPECT_DOUBLE_EQ(q.loops.distance, 3.0);
  EXPECT_DOUBLE_EQ(q.loops.icp_distance, 0.3);
  EXPECT_EQ(q.loops.icp_iterations, 80);
  EXPECT_DOUBLE_EQ(q.loops.lum_distance, 1.0);

  // 2D scans: the registered sample at 1.5 voxels, loops within 4 r, the front end's
  // normals from the local map (3D: from each scan unless asked).
  slam::Parameters planar;
  planar.planar = true;
  const slam::Parameters two_d = slam::resolve(planar, 8.0);
  EXPECT_DOUBLE_EQ(two_d.reduction.source_voxel_size, 0.6);
  EXPECT_DOUBLE_EQ(two_d.loops.distance, 32.0);
  EXPECT_TRUE(two_d.matcher.normals_from_map);
  EXPECT_FALSE(slam::resolve(slam::Parameters(), 8.0).matcher.normals_from_map);
}

TEST(Parameters, BadScaleOrSweepPeriodAndUnresolvedStagesAreRefused)
{
  slam::Parameters p;
  EXPECT_THROW(slam::resolve(p, 0.0), std::invalid_argument);
  EXPECT_THROW(slam::resolve(p, std::numeric_limits<double>::quiet_NaN()),
               std::invalid_argument);
  p.deskew.sweep_period = -0.1;
  EXPECT_THROW(slam::resolve(p, 8.0), std::invalid_argument);
  p.deskew.sweep_period = std::numeric_limits<double>::infinity();
  EXPECT_THROW(slam::resolve(p, 8.0), std::invalid_argument);
  slam::Parameters planar; // the planar modes move in the x-y plane
  planar.planar = true;
  planar.guess.up = Eigen::Vector3d::UnitY();
  EXPECT_THROW(slam::resolve(planar, 8.0), std::invalid_argument);
  planar.guess.up = -Eigen::Vector3d::UnitZ();
  EXPECT_NO_THROW(slam::resolve(planar, 8.0));
  EXPECT_THROW(slam::Matcher{slam::Parameters()}, std::invalid_argument);
  EXPECT_THROW(slam::LoopCloser{slam::Parameters()}, std::invalid_argument);
}

TEST(MotionModel, ConstantVelocityRepeatsTheLastStep)
{
  slam::MotionModel motion(0.0, 0.05);
  const slam::MotionPrediction first = motion.predict(std::nullopt, std::nullopt);
  EXPECT_TRUE(first.first);
  EXPECT_TRUE(first.pose.isIdentity());
  motion.update(Pose::Identity(), first, std::nullopt);
  const Pose step = makePose(5 * kDeg, 0.4, 0.1);
  const slam::MotionPrediction second = motion.predict(std::nullopt, std::nullopt);
  EXPECT_TRUE(second.pose.isIdentity()); // no velocity yet
  motion.update(step, second, std::nullopt);
  const slam::MotionPrediction third = motion.predict(std::nullopt, std::nullopt);
  EXPECT_TRUE(third.pose.isApprox(step * step, 1e-12));
  EXPECT_TRUE(third.step.isApprox(step, 1e-12));
  EXPECT_EQ(motion.scans(), 3u);
  EXPECT_TRUE(motion.heading().isApprox(Eigen::Vector3d(0.4, 0.1, 0.0).normalized(), 1e-12));
}

TEST(MotionModel, OdometryStepMovesFromTheMatchedPose)
{
  slam::MotionModel motion(0.0, 0.05);
  const Pose o0 = makePose(10 * kDeg, 1.0, 2.0), o1 = makePose(30 * kDeg, 1.5, 2.5);
  const slam::MotionPrediction m0 = motion.predict(o0, std::nullopt);
  EXPECT_TRUE(m0.pose.isApprox(o0, 1e-12)); // the first scan at its odometry pose
  const Pose matched = makePose(12 * kDeg, 1.1, 2.0);
  motion.update(matched, m0, std::nullopt);
  const slam::MotionPrediction m1 = motion.predict(o1, std::nullopt);
  EXPECT_TRUE(m1.step.isApprox(o0.inverse() * o1, 1e-12));
  EXPECT_TRUE(m1.pose.isApprox(matched * o0.inverse() * o1, 1e-12));
}

TEST(MotionModel, VelocityPerSecondIsClampedToFourTimesTheLastStep)
{
  slam::MotionModel motion(0.0, 0.05);
  motion.update(Pose::Identity(), motion.predict(std::nullopt, 0.0), 0.0);
  motion.update(makePose(0.0, 1.0, 0.0), motion.predict(std::nullopt, 1.0), 1.0);
  // 1 m in 1 s: 2 s later 2 m, 11 s later not 10 m but 4 (a hidden stop, docs/design.md).
  slam::MotionModel copy = motion;
  EXPECT_NEAR(motion.predict(std::nullopt, 3.0).step(0, 3), 2.0, 1e-12);
  EXPECT_NEAR(copy.predict(std::nullopt, 11.0).step(0, 3), 4.0, 1e-12);
}

TEST(MotionModel, CorrectionMovesTheLastPose)
{
  slam::MotionModel motion(0.0, 0.05);
  const Pose pose = makePose(20 * kDeg, 3.0, -1.0);
  motion.update(pose, motion.predict(std::nullopt, std::nullopt), std::nullopt);
  const Pose correction = makePose(-3 * kDeg, 0.2, 0.1);
  motion.applyCorrection(correction);
  EXPECT_TRUE(motion.lastPose().isApprox(correction * pose, 1e-12));
}

TEST(Deskewer, OffPassesTheScanUnchanged)
{
  const Cloud scan = room();
  slam::Deskewer off(false, true, 0.05, 0);
  const Cloud::Ptr out = off.deskew(scan, {}, makePose(10 * kDeg, 1.0, 0.0));
  ASSERT_EQ(out->size(), scan.size());
  for (std::size_t i = 0; i < scan.size(); ++i)
    ASSERT_EQ(out->points[i].getVector3fMap(), scan.points[i].getVector3fMap());
  off.holdFirst(scan, {});
  EXPECT_FALSE(off.holdsFirst());
}

TEST(Deskewer, HoldsTheFirstScanUntilReleased)
{
  const Cloud scan = room();
  const Pose sweep = makePose(8 * kDeg, 0.5, 0.0);
  slam::Deskewer on(true, true, 0.05, 0);
  on.holdFirst(scan, {});
  EXPECT_TRUE(on.holdsFirst());
  const Cloud::Ptr released = on.releaseFirst(sweep);
  EXPECT_FALSE(on.holdsFirst());
  const Cloud::Ptr direct = slam::deskewSweep(scan, {}, sweep, true, 0);
  ASSERT_EQ(released->size(), direct->size());
  for (std::size_t i = 0; i < direct->size(); ++i)
    ASSERT_EQ(released->points[i].getVector3fMap(), direct->points[i].getVector3fMap());
}

TEST(Deskewer, DeskewsAgainOnlyBeyondHalfAVoxel)
{
  // A translation t changes the farthest point by t / 2 (first order, skewChange).
  slam::Deskewer on(true, true, 0.1, 0);
  const Cloud scan = room();
  EXPECT_FALSE(on.needsAgain(Pose::Identity(), makePose(0.0, 0.09, 0.0), scan));
  EXPECT_TRUE(on.needsAgain(Pose::Identity(), makePose(0.0, 0.11, 0.0), scan));
}

/** The room as a scanner moving along `path` measures it: each point at the sweep time of
 *  its azimuth from the path's middle, in the scanner's frame then. */
std::pair<Cloud, std::vector<float>>
seenAlong(const Cloud& world, const slam::SweepPath& path)
{
  std::pair<Cloud, std::vector<float>> out;
  const Pose to_mid = path.mid().inverse();
  for (const auto& w : world) {
    const Eigen::Vector3d x = w.getVector3fMap().cast<double>();
    const double t = slam::sweepTime(
        Eigen::Vector3d(to_mid.topLeftCorner<3, 3>() * x + to_mid.topRightCorner<3, 1>()));
    const Pose to_scanner = path.at(t).inverse();
    pcl::PointXYZ p;
    p.getVector3fMap() =
        (to_scanner.topLeftCorner<3, 3>() * x + to_scanner.topRightCorner<3, 1>())
            .cast<float>();
    out.first.push_back(p);
    out.second.push_back(static_cast<float>(t));
  }
  return out;
}

// A path at one velocity is the deskewing's constant-velocity motion: its knots lie on
// that screw motion, and deskewing along it is deskewing by the motion.
TEST(SweepPath, AtOneVelocityIsTheDeskewingsMotion)
{
  const Pose mid = makePose(10 * kDeg, 1.0, 2.0), sweep = makePose(25 * kDeg, 0.6, 0.1);
  const slam::SweepPath path(mid, sweep, 4);
  ASSERT_EQ(path.knots().size(), 5u);
  EXPECT_TRUE(path.mid().isApprox(mid, 1e-12));
  EXPECT_TRUE(
      Pose(path.knots().front().inverse() * path.knots().back()).isApprox(sweep, 1e-12));
  const Cloud scan = room();
  std::vector<float> times(scan.size());
  for (std::size_t i = 0; i < scan.size(); ++i)
    times[i] = static_cast<float>(slam::sweepTime(scan[i]));
  const Cloud::Ptr along = slam::deskewAlong(scan, times, path, 2);
  const Cloud::Ptr deskewed = slam::deskew(scan, times, sweep, 2);
  ASSERT_EQ(along->size(), scan.size());
  for (std::size_t i = 0; i < scan.size(); ++i)
    ASSERT_LT(((*along)[i].getVector3fMap() - (*deskewed)[i].getVector3fMap()).norm(), 1e-5)
        << i;
  EXPECT_THROW(slam::SweepPath(mid, sweep, 0), std::invalid_argument);
}

/** A hand-held turn that speeds up within the sweep (2, 6, 12 and 20 degrees over its
 *  quarters), pitching, 0.4 m forward, about the map's origin. */
slam::SweepPath
speedingTurn()
{
  slam::SweepPath path(Pose::Identity(), Pose::Identity(), 4);
  slam::Poses& k = path.knots();
  const double turns[4] = {2 * kDeg, 3 * kDeg, 5 * kDeg, 8 * kDeg};
  k[0] = makePose(-15 * kDeg, -0.2, 0.1);
  for (std::size_t j = 0; j < 4; ++j) {
    Pose pitch = Pose::Identity();
    pitch.topLeftCorner<3, 3>() =
        Eigen::AngleAxisd((j < 2 ? 2.0 : -2.0) * kDeg, Eigen::Vector3d::UnitY()).matrix();
    k[j + 1] = k[j] * makePose(turns[j], 0.1, 0.0) * pitch;
  }
  return path;
}

// The sweep's path fitted to the map: from the constant velocity of the sweep's whole
// motion (what deskewing by the step assumes), the fit follows the turn speeding up. Its
// worst knot ends within a quarter of the constant velocity's angle of the truth (5.7 ->
// 1.1 degrees; the prior's stiffness holds the sparse ends back), the same for any thread
// count.
TEST(Matcher, FitsTheSweepPathOfATurnThatSpeedsUp)
{
  const slam::Parameters p = roomParameters(slam::MatchTarget::kLocalMap);
  const slam::Reducer reducer(p.reduction.voxel_size, p.reduction.source_voxel_size, 0);
  slam::ReducedScan map = reducer.reduce(room(1));
  reducer.describe(map);
  const slam::SweepPath truth = speedingTurn();
  // Named, not structured bindings: C++17 lambdas cannot capture those (clang refuses).
  const std::pair<Cloud, std::vector<float>> seen = seenAlong(room(2), truth);
  const Cloud& raw = seen.first;
  const std::vector<float>& times = seen.second;
  const slam::Deskewer deskewer(true, true, p.reduction.voxel_size, 0);
  const std::pair<Cloud::Ptr, std::vector<float>> sampled =
      deskewer.timedSample(raw, times, p.reduction.source_voxel_size);
  const Cloud& sample = *sampled.first;
  const std::vector<float>& sample_times = sampled.second;
  const Pose whole = truth.knots().front().inverse() * truth.knots().back();
  const slam::SweepPath start(truth.mid(), whole, 4);
  // The path from `start` fitted by a matcher on `threads` threads, its map the room's
  // first view (the map's tree is built by a match); none where the match or fit fails.
  const auto fit = [&](unsigned threads) -> std::optional<slam::SweepPath> {
    slam::Parameters q = p;
    q.num_threads = threads;
    slam::Matcher matcher(q);
    matcher.keep(map, Pose::Identity(), 1);
    if (!matcher.match(reducer.source(reducer.reduce(*slam::deskewAlong(raw, times, start, 0))),
                       truth.mid(),
                       truth.mid(),
                       Pose::Identity()))
      return std::nullopt;
    slam::SweepPath path = start;
    if (!matcher.fitPath(path, sample, sample_times, slam::SweepPathPrior{}))
      return std::nullopt;
    return path;
  };
  const auto worst = [&](const slam::SweepPath& path) {
    PoseError w{0.0, 0.0};
    for (std::size_t j = 0; j < truth.knots().size(); ++j) {
      const PoseError e = poseError(path.knots()[j], truth.knots()[j]);
      w.distance = std::max(w.distance, e.distance);
      w.angle = std::max(w.angle, e.angle);
    }
    return w;
  };
  const std::optional<slam::SweepPath> fitted = fit(p.num_threads);
  ASSERT_TRUE(fitted);
  const PoseError before = worst(start), after = worst(*fitted);
  std::printf("sweep path's worst knot: constant velocity %.4f m, %.3f deg; fitted %.4f m, "
              "%.3f deg\n",
              before.distance,
              before.angle / kDeg,
              after.distance,
              after.angle / kDeg);
  EXPECT_GT(before.angle, 4.0 * kDeg);
  EXPECT_LT(after.angle, 0.25 * before.angle);
  EXPECT_LT(after.distance, 0.6 * before.distance);
  const std::optional<slam::SweepPath> serial = fit(1);
  ASSERT_TRUE(serial);
  for (std::size_t j = 0; j < truth.knots().size(); ++j)
    EXPECT_EQ(serial->knots()[j], fitted->knots()[j]) << j;
}

// A sample deskewed by one motion, deskewed again by another without its raw points: each
// point's time from its deskewed azimuth, within that motion's turn of the measured one.
// Against the raw scan deskewed by the other motion, it is off by a small share of how far
// the change of motion moves the points; switched off, a copy.
TEST(Deskewer, AgainMovesAPointAsDeskewingItsRawPointWould)
{
  const Cloud scan = room();
  const Pose from = makePose(25 * kDeg, 0.6, 0.1), to = makePose(5 * kDeg, 0.2, 0.0);
  const slam::Deskewer on(true, true, 0.05, 2);
  const Cloud::Ptr deskewed = on.deskew(scan, {}, from);
  const Cloud::Ptr again = on.again(*deskewed, from, to);
  const Cloud::Ptr direct = on.deskew(scan, {}, to);
  ASSERT_EQ(again->size(), scan.size());
  // Where the deskewing moves a point by a fair share of its distance from the vertical,
  // its azimuth, and so its time, is no longer its own: those are left out.
  double change = 0.0, error = 0.0, sum = 0.0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const Eigen::Vector3f p = (*direct)[i].getVector3fMap();
    const double moved = ((*deskewed)[i].getVector3fMap() - p).norm();
    const double e = ((*again)[i].getVector3fMap() - p).norm();
    sum += e;
    if (scan[i].getVector3fMap().head<2>().norm() < 4.0 * moved)
      continue;
    change = std::max(change, moved);
    error = std::max(error, e);
    ++n;
  }
  std::printf("deskewed again: worst %.4f m off (%zu of %zu points), mean %.4f m (all); the "
              "motions' change %.3f m\n",
              error,
              n,
              scan.size(),
              sum / scan.size(),
              change);
  EXPECT_GT(n, scan.size() * 3 / 4);
  EXPECT_GT(change, 0.3);
  EXPECT_LT(error, 0.05 * change);
  EXPECT_LT(sum / scan.size(), 0.01 * change);
  const slam::Deskewer off(false, true, 0.05, 2);
  const Cloud::Ptr copy = off.again(scan, from, to);
  for (std::size_t i = 0; i < scan.size(); ++i)
    ASSERT_EQ((*copy)[i].getVector3fMap(), scan[i].getVector3fMap());
}

TEST(Reducer, ReducesAsTheVoxelFilters)
{
  const Cloud scan = room();
  const slam::Reducer reducer(0.05, 0.15, 0);
  slam::ReducedScan reduced = reducer.reduce(scan);
  const Cloud::Ptr expected = filters::voxelCentroid(scan, 0.05, 0);
  ASSERT_EQ(reduced.reduced->size(), expected->size());
  for (std::size_t i = 0; i < expected->size(); ++i)
    ASSERT_EQ(reduced.reduced->points[i].getVector3fMap(),
              expected->points[i].getVector3fMap());
  const Cloud::Ptr source = reducer.source(reduced);
  const Cloud::Ptr expected_source = filters::voxelNearestToCentroid(*expected, 0.15, 0);
  ASSERT_EQ(source->size(), expected_source->size());
  EXPECT_LT(source->size(), reduced.reduced->size());
}

TEST(Reducer, DescribesOnceWithTheSurfacesNormals)
{
  const slam::Reducer reducer(0.05, 0.15, 0);
  slam::ReducedScan scan = reducer.reduce(room());
  EXPECT_FALSE(scan.tree);
  reducer.describe(scan);
  ASSERT_TRUE(scan.tree);
  EXPECT_EQ(scan.tree->size(), scan.reduced->size());
  ASSERT_EQ(scan.normals.size(), scan.reduced->size());
  // Points on the floor (z = -1.2), 0.3 m from walls and box: their normals are vertical.
  std::size_t floor = 0, vertical = 0;
  for (std::size_t i = 0; i < scan.reduced->size(); ++i) {
    const auto& p = scan.reduced->points[i];
    if (std::abs(p.z + 1.2f) < 0.01f && std::abs(p.x) < 1.0f && p.y > -1.1f && p.y < -0.6f) {
      ++floor;
      vertical += std::abs(scan.normals[i].z()) > 0.99f ? 1 : 0;
    }
  }
  ASSERT_GT(floor, 50u);
  EXPECT_GT(vertical, 0.95 * floor);
  const auto tree = scan.tree;
  reducer.describe(scan);
  EXPECT_EQ(scan.tree, tree); // built once
}

/** The matcher on the room's first view, then the second view from `start`. */
void
expectMatch(slam::MatchTarget target)
{
  const slam::Parameters p = roomParameters(target);
  const slam::Reducer reducer(p.reduction.voxel_size, p.reduction.source_voxel_size, 0);
  slam::Matcher matcher(p);
  EXPECT_FALSE(matcher.hasTarget());
  slam::ReducedScan first = reducer.reduce(room(1));
  reducer.describe(first);
  matcher.keep(first, Pose::Identity(), 1);
  ASSERT_TRUE(matcher.hasTarget());
  const Pose truth = makePose(4 * kDeg, 0.15, -0.1, 0.02);
  const slam::ReducedScan second = reducer.reduce(seenFrom(room(2), truth));
  const Cloud::Ptr source = reducer.source(second);
  const auto matched =
      matcher.match(source, Pose::Identity(), Pose::Identity(), Pose::Identity());
  ASSERT_TRUE(matched);
  const PoseError e = poseError(*matched, truth);
  EXPECT_LT(e.distance, 0.01);
  EXPECT_LT(e.angle, 0.2 * kDeg);
  slam::ScanRecord record;
  record.pose = *matched;
  record.report.gate = matcher.gate();
  matcher.measure(record, source);
  EXPECT_GT(record.information_pairs, 0.5 * source->size());
  EXPECT_GT(record.information.ldlt().vectorD().minCoeff(), 0.0); // all six constrained
  // Two samplings of the same surfaces: pairs about a voxel apart, not a wall's width.
  EXPECT_LT(record.report.fitness, p.reduction.voxel_size * p.reduction.voxel_size);
}

TEST(Matcher, RecoversAStepToThePreviousScan)
{
  expectMatch(slam::MatchTarget::kPreviousScan);
}

TEST(Matcher, RecoversAStepToTheLocalMap)
{
  expectMatch(slam::MatchTarget::kLocalMap);
}

/** A room kept, then a corner of another room 6 m away (floor and two walls: all six
 *  degrees constrained) with under a tenth of the map's points; `source` sees the corner
 *  alone after `step`. `normals_from_map`: the map's points get their normals from the
 *  map around them, else they keep the scans' own. */
struct CornerAfterRoom {
  explicit CornerAfterRoom(bool normals_from_map)
      : p(withMapNormals(roomParameters(slam::MatchTarget::kLocalMap), normals_from_map))
      , reducer(p.reduction.voxel_size, p.reduction.source_voxel_size, 0)
      , matcher(p)
  {
    slam::ReducedScan seen = reducer.reduce(room(1));
    reducer.describe(seen);
    matcher.keep(seen, Pose::Identity(), 1);
    Cloud corner;
    for (const auto& q : room(2))
      if (q.x < -1.4f && q.y < -0.7f)
        corner.push_back(q);
    slam::ReducedScan previous = reducer.reduce(corner);
    reducer.describe(previous);
    corner_points = previous.reduced->size();
    room_points = seen.reduced->size();
    matcher.keep(previous, at, 2);
    source = reducer.source(reducer.reduce(seenFrom(corner, step)));
  }
  static slam::Parameters
  withMapNormals(slam::Parameters p, bool on)
  {
    p.matcher.normals_from_map = on;
    return p;
  }
  slam::Parameters p;
  slam::Reducer reducer;
  slam::Matcher matcher;
  const Pose at = makePose(0.0, 6.0, 0.0);
  const Pose step = makePose(3 * kDeg, 0.05, 0.03, 0.01);
  std::size_t room_points = 0, corner_points = 0;
  Cloud::Ptr source;
};

// The map holds the scan kept just before, with normals: a scan that sees only what the
// last one saw is matched to it (the hand-held scanner turning into a new room), also
// where the normals come from the map (a sparse scanner's, a 2D scanner's).
TEST(Matcher, MatchesAgainstTheScanKeptJustBefore)
{
  for (const bool normals_from_map : {false, true}) {
    SCOPED_TRACE(normals_from_map ? "normals from the map" : "the scans' normals");
    CornerAfterRoom s(normals_from_map);
    ASSERT_LT(s.corner_points, s.room_points / 10); // a rebuild at 10 % new points lags
    const std::optional<Pose> matched = s.matcher.match(s.source, s.at, s.at, s.at);
    ASSERT_TRUE(matched);
    const Pose error = (s.at * s.step).inverse() * *matched;
    EXPECT_LT((error.topRightCorner<3, 1>().norm()), 0.01);
    EXPECT_LT(Eigen::AngleAxisd(Eigen::Matrix3d(error.topLeftCorner<3, 3>())).angle(),
              0.5 * kDeg);
    slam::ScanRecord record;
    record.pose = *matched;
    record.report.gate = s.matcher.gate();
    s.matcher.measure(record, s.source);
    EXPECT_GT(record.information_pairs, 0.5 * s.source->size());
    EXPECT_GT(record.information.ldlt().vectorD().minCoeff(), 0.0); // all six constrained
  }
}

/** The second view of the room turned by `yaw` and moved, guessed without odometry from
 *  a prediction of no motion. `sweeping`: seen by a scanner that sweeps through the whole
 *  step (a hand-held LiDAR's slow sweep), each start judged on the scan deskewed by its
 *  own motion where `own_deskewing`, as the pipeline does. */
std::pair<Pose, slam::ScanRecord>
guessTurn(double yaw, bool odometry, bool sweeping = false, bool own_deskewing = false)
{
  const slam::Parameters p = roomParameters(slam::MatchTarget::kLocalMap);
  slam::MotionModel motion(0.0, p.reduction.voxel_size);
  const slam::Reducer reducer(p.reduction.voxel_size, p.reduction.source_voxel_size, 0);
  slam::Matcher matcher(p);
  slam::PoseGuess guess(p, matcher, reducer, motion);
  const slam::MotionPrediction m0 = motion.predict(std::nullopt, std::nullopt);
  slam::ReducedScan first = reducer.reduce(room(1));
  reducer.describe(first);
  matcher.keep(first, m0.pose, 1);
  motion.update(m0.pose, m0, std::nullopt);

  const Pose truth = makePose(yaw, 0.3, 0.2);
  slam::ReducedScan second =
      reducer.reduce(sweeping ? seenAlong(room(2), slam::SweepPath(truth, truth, 4)).first
                              : seenFrom(room(2), truth));
  slam::ScanRecord r;
  const slam::MotionPrediction m = motion.predict(std::nullopt, std::nullopt);
  r.prediction = m.pose;
  const slam::Deskewer deskewer(true, true, p.reduction.voxel_size, 0);
  const slam::PoseGuess::StartDeskew own = [&](const Cloud& cloud, const Pose& start) {
    const Pose sweep = motion.sweepOfMatch(start, m);
    return deskewer.needsAgain(m.sweep, sweep, *second.reduced)
               ? deskewer.again(cloud, m.sweep, sweep)
               : Cloud::Ptr();
  };
  const Pose start = guess.guess(reducer.source(second),
                                 second,
                                 odometry,
                                 r,
                                 own_deskewing ? own : slam::PoseGuess::StartDeskew());
  return {start, r};
}

TEST(PoseGuess, WithOdometryStartsAtThePrediction)
{
  const auto [start, r] = guessTurn(60 * kDeg, true);
  EXPECT_EQ(start, r.prediction);
  EXPECT_FALSE(r.report.pose_searched);
}

TEST(PoseGuess, FindsATurnNothingPredicted)
{
  // 60 degrees: far outside pICP's basin from the prediction (no motion); the room with
  // its box has no such symmetry, so only the search's heading can explain the scan.
  const auto [start, r] = guessTurn(60 * kDeg, false);
  EXPECT_TRUE(r.report.pose_searched);
  const PoseError e = poseError(start, makePose(60 * kDeg, 0.3, 0.2));
  EXPECT_LT(e.distance, 0.03);
  EXPECT_LT(e.angle, 1.0 * kDeg);
  EXPECT_NEAR(r.report.start_heading, 60 * kDeg, 10 * kDeg);
}

// A turn nothing predicted, seen by a slow sweep: the scan is bent by up to half the turn
// at the sweep's ends. The search's candidates are matched and judged on the scan deskewed
// by the motion each implies, until the match settles: 0.5 degrees off the truth; on the
// prediction's deskewing (no motion) the start ends 13 degrees off.
TEST(PoseGuess, JudgesTheSearchsCandidatesOnTheirOwnDeskewing)
{
  const Pose truth = makePose(40 * kDeg, 0.3, 0.2);
  const auto [bent, r_bent] = guessTurn(40 * kDeg, false, true, false);
  const auto [own, r_own] = guessTurn(40 * kDeg, false, true, true);
  EXPECT_TRUE(r_own.report.pose_searched);
  const PoseError e_bent = poseError(bent, truth), e_own = poseError(own, truth);
  std::printf("search start of a swept 40 degree turn: on the prediction's deskewing %.4f m, "
              "%.3f deg; on its own %.4f m, %.3f deg\n",
              e_bent.distance,
              e_bent.angle / kDeg,
              e_own.distance,
              e_own.angle / kDeg);
  EXPECT_GT(e_bent.angle, 5.0 * kDeg); // the sweep bends the scan that much
  EXPECT_LT(e_own.angle, 1.0 * kDeg);
  EXPECT_LT(e_own.distance, 0.02);
}

// Keyframes seconds apart deskewed as if consecutive sweeps are bent by their whole step:
// a warning, unless the sweep period is given, deskewing is off, or the stamps are a sweep
// apart.
TEST(Findings, KeyframesDeskewedWithoutASweepPeriodAreWarned)
{
  std::vector<double> stamps;
  for (int k = 0; k < 7; ++k)
    stamps.push_back(100.0 + 0.5 * k + (k % 2 ? 0.15 : 0.0)); // 0.35-0.65 s apart
  slam::DeskewParameters deskew;
  deskew.enabled = true;
  EXPECT_NE(slam::keyframeWarning(stamps, deskew).find("median 0.65 s apart"),
            std::string::npos);
  deskew.sweep_period = 0.1;
  EXPECT_EQ(slam::keyframeWarning(stamps, deskew), "");
  deskew.sweep_period = 0.0;
  deskew.enabled = false;
  EXPECT_EQ(slam::keyframeWarning(stamps, deskew), "");
  deskew.enabled = true;
  for (std::size_t k = 0; k < stamps.size(); ++k)
    stamps[k] = 100.0 + 0.1 * static_cast<double>(k); // 10 Hz sweeps
  EXPECT_EQ(slam::keyframeWarning(stamps, deskew), "");
  EXPECT_EQ(slam::keyframeWarning({100.0}, deskew), "");
}

TEST(Findings, DeskewNoteSaysWhichTimesWereUsed)
{
  EXPECT_EQ(slam::deskewNote(0, 5, false), "");
  EXPECT_NE(slam::deskewNote(2, 5, false).find("carry per-point times"), std::string::npos);
  EXPECT_EQ(slam::deskewNote(5, 5, true), "deskewed by the points' time field");
  EXPECT_NE(slam::deskewNote(0, 5, true).find("by azimuth"), std::string::npos);
  EXPECT_NE(slam::deskewNote(2, 5, true).find("in 2 of 5 scans"), std::string::npos);
}

// Each finding appears exactly when its condition holds, naming the scans by their numbers.
TEST(Findings, NameThePoseSearchTheOdometryAndTheWorstSteps)
{
  slam::MappingResult r;
  r.reports.resize(4);
  const std::vector<int> numbers{10, 11, 12, 13};
  EXPECT_TRUE(slam::findings(r, numbers).empty());
  r.pose_searched = 3;
  r.pose_search_won = 2;
  r.odometry_disagreement = slam::kOdometryDisagreementLimit / 2;
  auto found = slam::findings(r, numbers);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_NE(found[0].text.find("3 of 3 matches searched (no initial poses), 2 placed"),
            std::string::npos);
  EXPECT_FALSE(found[0].input_suspect);
  r.pose_search_won = 0;
  r.odometry_disagreement = 2.0 * slam::kOdometryDisagreementLimit;
  r.reports[2].sequence_chi2 = 1e6; // beyond any notable threshold
  r.reports[3].sequence_chi2 = 2e6;
  found = slam::findings(r, numbers);
  ASSERT_EQ(found.size(), 2u);
  EXPECT_TRUE(found[0].input_suspect);
  EXPECT_NE(found[0].text.find("0.50 times as far"), std::string::npos);
  EXPECT_NE(found[1].text.find("scans 13 (chi2 2000000), 12 (chi2 1000000)"),
            std::string::npos);
}

} // namespace
