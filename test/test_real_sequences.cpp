/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The front end on the two real LiDAR keyframe sequences of ../shared/data (see their
 * PROVENANCE.txt), as `pcl_pslam run --no-loops` runs it: a handheld Livox swung in one
 * room with FAST-LIO2's odometry, and an Ouster car drive without any poses. Neither has
 * ground truth; each test asserts what a defect would break and the data can tell.
 */
#include "car_sequence.h"
#include "test_data.h"

#include <pcl_parallel/evaluation/trajectory_error.h>
#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/slam/pipeline.h>

#include <algorithm>
#include <cstdio>
#include <gtest/gtest.h>
#include <string>
#include <utility>
#include <vector>

namespace {

using namespace pcl_parallel;
using slam::Pose;
using slam::Poses;

using test::kSanitized; // fewer scans under a sanitizer

using test::mapSequence;

/** fastlio_quick_shack's first n scans mapped from its odometry (the file): the per-step
 *  errors against its optimised poses. */
evaluation::FrameRelativeError
handheldStepErrors(const std::string& odometry_file, std::size_t n, bool close_loops)
{
  const Poses odometry = io::loadKittiPoses(odometry_file);
  const Poses reference =
      io::loadKittiPoses(test::dataFile("fastlio_quick_shack/optimized_poses.txt"));
  EXPECT_EQ(odometry.size(), 241u);
  const Poses poses =
      mapSequence(test::dataFile("fastlio_quick_shack/bin"), n, &odometry, close_loops);
  EXPECT_EQ(poses.size(), n);
  return evaluation::frameRelativeError(poses, Poses(reference.begin(), reference.begin() + n));
}

void
expectStepErrorsBelow(const evaluation::FrameRelativeError& e,
                      double rotation_mean_deg,
                      double rotation_max_deg,
                      double translation_mean)
{
  EXPECT_LT(e.rotation_deg.mean, rotation_mean_deg);
  EXPECT_LT(e.rotation_deg.max, rotation_max_deg);
  EXPECT_LT(e.translation.mean, translation_mean);
}

// Handheld Livox Avia swung ~10 degrees between keyframes, FAST-LIO2's (IMU-aided)
// odometry given: the front end must keep what the odometry got right. Its steps against
// the optimised poses (FAST-LIO2 + Scan-Context/iSAM2; step by step the same as the
// odometry's to 0.03 degrees mean): rotation 0.159 degrees mean, 0.85 worst; translation
// 1.7 cm mean, 9.8 cm worst (registering voxel centroids instead of measured points 0.148,
// 0.58, 1.7 cm, 8.5 cm: docs/design.md, "Sampling the registered points"; before the
// front end's coarse-to-fine refinement 0.118, 0.76, 1.6 cm, 14 cm: refined, the steps
// follow the sparse scans more and FAST-LIO2's IMU-aided ones less on average;
// docs/design.md, "Coarse to fine"). With the prior's spread taken from
// the combined model error (rotation weighed at max range) the matches drifted through the
// close, nearly planar views of scans 112-137: 0.26 degrees, 1.09 worst; 2.8 cm, 29 cm worst.
TEST(RealSequences, HandheldFrontEndKeepsTheOdometrysSteps)
{
  PCL_PARALLEL_REQUIRE_DATA(odometry_file, "fastlio_quick_shack/odom_poses.txt");
  const auto e = handheldStepErrors(odometry_file, kSanitized ? 30 : 241, false);
  if (kSanitized)
    return; // the run above is what the sanitizers look at
  expectStepErrorsBelow(e, 0.17, 1.0, 0.025);
  EXPECT_LT(e.translation.max, 0.2);
}

// The same with loop closing (pLUM over 50-60 loop links): the relaxation must not bend
// the steps the front end got right. Where the swung scanner sees only a close, nearly
// planar patch (scans 112-137) pLUM's links of two reduced scans leave directions open;
// the front end's steps, as sequence constraints, must hold them. Measured: 0.147 degrees
// mean, 0.75 worst (0.175, 0.87 registering voxel centroids; 0.142, 1.47 before the front
// end's coarse-to-fine refinement). With the constraints' Cauchy kernel judged by their own
// information (chi2 in the thousands there) they yielded to whatever the loops pulled:
// 0.232, 3.29.
TEST(RealSequences, HandheldLoopClosingKeepsTheSteps)
{
  PCL_PARALLEL_REQUIRE_DATA(odometry_file, "fastlio_quick_shack/odom_poses.txt");
  if (kSanitized)
    GTEST_SKIP() << "loop closing over 241 scans: too slow under the sanitizers";
  expectStepErrorsBelow(handheldStepErrors(odometry_file, 241, true), 0.18, 2.0, 0.025);
}

// The same scanner without odometry: the front end from constant velocity alone. The
// swings change the motion between keyframes far more than constant velocity predicts,
// so the local-map match starts from a match to the previous scan
// (PoseGuessParameters::guess_from_previous_scan), the best of it and of the predicted turn
// stopped and doubled (the turn-rate hypotheses; docs/design.md, "Speed hypotheses").
// Measured: per-step rotation error 0.40 degrees mean, 4.9 worst (0.61, 8.6 registering
// voxel centroids); without the turn-rate hypotheses 1.44 and 17.6 (they lost the fastest
// swings, scans 114-140); from constant velocity itself 5.0 mean.
TEST(RealSequences, HandheldFrontEndWithoutOdometry)
{
  PCL_PARALLEL_REQUIRE_DATA(reference_file, "fastlio_quick_shack/optimized_poses.txt");
  const std::size_t n = kSanitized ? 30 : 241;
  slam::Parameters p;
  p.loops.enabled = false;
  p.num_threads = 2;
  std::vector<slam::ScanReport> reports;
  const std::string dir = test::dataFile("fastlio_quick_shack/bin");
  // With the keyframes' stamps, as `pcl_pslam run` takes times.txt.
  const std::vector<double> stamps =
      io::loadKittiTimes(test::dataFile("fastlio_quick_shack/times.txt"));
  const Poses poses = mapSequence(dir, n, p, nullptr, &stamps, &reports);
  ASSERT_EQ(poses.size(), n);
  if (kSanitized)
    return; // the run above is what the sanitizers look at
  const Poses reference = io::loadKittiPoses(reference_file);
  const auto e = evaluation::frameRelativeError(poses, reference).rotation_deg;
  std::printf("handheld without odometry: per-step rotation error %.2f deg mean, %.2f worst\n",
              e.mean,
              e.max);
  EXPECT_LT(e.mean, 0.6);
  EXPECT_LT(e.max, 8.0);
  EXPECT_TRUE(std::any_of(reports.begin(), reports.end(), [](const slam::ScanReport& r) {
    return r.start_turn != 0.0;
  })) << "no turn-rate hypothesis won";
  p.num_threads = 1;
  EXPECT_EQ(mapSequence(dir, n, p, nullptr, &stamps), poses);
}

using test::carProgress;

// An Ouster OS1-64 on a car, keyframes 0.4-5.5 s apart, no odometry (the data's poses are
// unusable, PROVENANCE.txt): from constant velocity alone the front end must follow the
// drive. The car moves along -x of the scans' frame (PROVENANCE.txt) and the clip ends
// far from where it began. Where the car pulls away (keyframes 5-60), scan-to-scan
// matching and a brute-force overlap search find steps of 5-9 m (docs/design.md, "Real
// data"), 300 m in all. Measured: 98.5 % of the steps go forward, 405 m to keyframe 60,
// the last pose 732 m from the first (100 %, 300 m, 795 m before the speed hypotheses;
// 99 %, 272 m, 863 m before the coarse-to-fine refinement; with a refinement whose kernel
// went below the residual spread: 92 %, 153 m).
// Matched to the local map from constant velocity the front end stalled there: 85 %, 47 m (and
// 1,043 m); with the prior's spread from the combined model error it lost the street and
// wandered in a 100 m tangle: 50 %, 30 m. With speed hypotheses that could start behind the
// previous keyframe, the creeping start zig-zagged (keyframes 1-11: 30 m of steps, 0.8 m
// net; 98.5 %, 400 m, 746 m); now 100 %, 401 m, 809 m.
TEST(RealSequences, CarFrontEndFollowsTheDriveWithoutOdometry)
{
  PCL_PARALLEL_REQUIRE_DATA(dir, "mulran_riverside02_keyframes/bin");
  if (kSanitized)
    GTEST_SKIP() << "332 Ouster sweeps: too slow under the sanitizers; the handheld test "
                    "runs the same code there";
  const std::size_t n = 332;
  const Poses poses = mapSequence(dir, n);
  ASSERT_EQ(poses.size(), n);
  const auto [forward, pull_away] = carProgress(poses);
  const double end_to_start =
      (poses.back().topRightCorner<3, 1>() - poses.front().topRightCorner<3, 1>()).norm();
  std::printf("mulran without time stamps: %.1f %% of the steps forward, %.0f m to keyframe "
              "60, the last pose %.0f m from the first\n",
              100.0 * forward,
              pull_away,
              end_to_start);
  EXPECT_GT(forward, 0.995); // at most one of 331 steps backwards
  EXPECT_GT(pull_away, 200.0);
  EXPECT_GT(end_to_start, 500.0);
}

// The pull-away with the time stamps, deskewed by one sweep (`pcl_pslam run BIN -s S
// --deskew --sweep-period 0.1 --no-loops`). Constant velocity lags the car as it speeds
// up to ~14 m/s, and along the street a match started metres short converges to a false
// fit near the previous pose (from 0-2 m short of keyframe 18's 7.2 m step, pICP ends at
// +0.7 m, fitness 1.15 against 0.73), which then sets the velocity; the speed hypotheses
// (PoseGuessParameters::speed_hypotheses) must catch up with the car, against the local
// map and scan-to-scan (--scan-to-scan), each from a start keyframe of its own: the path
// to keyframe 60 over 250 m and every step of keyframes 20-46 over 4 m. 1 and 2 threads:
// the same poses. `pcl_parallel_bench real-car` runs both from each of keyframes 0-3.
TEST(RealSequences, CarPullsAwayFromAnyStartKeyframe)
{
  PCL_PARALLEL_REQUIRE_DATA(dir, "mulran_riverside02_keyframes/bin");
  PCL_PARALLEL_REQUIRE_DATA(times_file, "mulran_riverside02_keyframes/times.txt");
  if (kSanitized)
    GTEST_SKIP() << "2 x 70 Ouster sweeps: too slow under the sanitizers; the handheld "
                    "test runs the same code there";
  const std::vector<double> times = io::loadKittiTimes(times_file);
  const std::size_t n = 70;
  ASSERT_GE(times.size(), n);
  slam::Parameters p = test::deskewedFrontEnd(0.1);
  for (const auto& [target, first] :
       {std::pair{slam::MatchTarget::kLocalMap, std::size_t{0}},
        std::pair{slam::MatchTarget::kPreviousScan, std::size_t{2}}}) {
    p.matcher.target = target;
    const char* mode = target == slam::MatchTarget::kLocalMap ? "local map" : "scan-to-scan";
    const test::CarPullAway r = test::carPullAway(dir, times, n, first, p);
    ASSERT_EQ(r.poses.size(), n - first);
    std::printf("mulran, %s, from keyframe %zu: %.0f m to keyframe 60, steps of keyframes "
                "20-46 over %.2f m\n",
                mode,
                first,
                r.pull_away,
                r.shortest);
    EXPECT_GT(r.pull_away, 250.0) << mode << " from keyframe " << first;
    EXPECT_GT(r.shortest, 4.0) << mode << " from keyframe " << first;
    // Catching up with the car takes a start ahead of constant velocity.
    EXPECT_TRUE(r.started_ahead) << mode << " from keyframe " << first;
    if (target == slam::MatchTarget::kLocalMap) {
      p.num_threads = 1;
      EXPECT_EQ(mapSequence(dir, n, p, nullptr, &times), r.poses) << "1 thread";
      p.num_threads = 2;
    }
  }
}

} // namespace
