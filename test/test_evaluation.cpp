/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Trajectory errors (evaluation/) against hand-computed answers, and the pose files
 * (io/pose_files.h): round trips, the existing 3DTK reader, errors naming file and line.
 */
#include "error_message.h"
#include "scratch_dir.h"
#include "test_data.h"

#include <pcl_parallel/evaluation/alignment.h>
#include <pcl_parallel/evaluation/pose_error.h>
#include <pcl_parallel/evaluation/relations.h>
#include <pcl_parallel/evaluation/report.h>
#include <pcl_parallel/evaluation/trajectory_error.h>
#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/uos.h>

#include <Eigen/Geometry>

#include <cmath>
#include <filesystem>
#include <gtest/gtest.h>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

using pcl_parallel::test::messageOf;

namespace {

namespace ev = pcl_parallel::evaluation;
namespace pio = pcl_parallel::io;
using ev::Poses;
using pcl_parallel::test::ScratchDir;

constexpr double kDeg = M_PI / 180.0;

Eigen::Matrix4d
makePose(const Eigen::Matrix3d& r, const Eigen::Vector3d& t)
{
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = r;
  m.topRightCorner<3, 1>() = t;
  return m;
}

Eigen::Matrix3d
rotZ(double a)
{
  return Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

/** n poses on a circle of radius r in the xy-plane, heading along it. */
Poses
circle(std::size_t n, double r)
{
  Poses p;
  for (std::size_t i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * static_cast<double>(i) / static_cast<double>(n);
    p.push_back(
        makePose(rotZ(a + M_PI / 2), Eigen::Vector3d(r * std::cos(a), r * std::sin(a), 0)));
  }
  return p;
}

/** n poses along x, 1 m apart (path distances exactly 0, 1, 2, ...). */
Poses
line(std::size_t n)
{
  Poses p;
  for (std::size_t i = 0; i < n; ++i)
    p.push_back(makePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(double(i), 0, 0)));
  return p;
}

Poses
randomPoses(std::size_t n, std::uint32_t seed)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Poses p;
  for (std::size_t i = 0; i < n; ++i) {
    Eigen::Quaterniond q(u(rng), u(rng), u(rng), u(rng));
    q.normalize();
    p.push_back(makePose(q.toRotationMatrix(), 50.0 * Eigen::Vector3d(u(rng), u(rng), u(rng))));
  }
  return p;
}

void
expectPosesNear(const Poses& a, const Poses& b, double tol)
{
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    EXPECT_LT((a[i] - b[i]).cwiseAbs().maxCoeff(), tol) << "pose " << i;
}

// ---------------------------------------------------------------- pose errors

TEST(PoseError, AngleAndDistance)
{
  const Eigen::Matrix3d ra = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) *
                              Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()))
                                 .toRotationMatrix();
  const Eigen::Vector3d axis = Eigen::Vector3d(1, 2, 2) / 3.0;
  const Eigen::Matrix4d a = makePose(ra, Eigen::Vector3d(1, 2, 3));
  for (const double angle : {0.7, 1e-8, 3.1}) { // small: acos((tr - 1) / 2) would give 0
    const Eigen::Matrix4d b = makePose(ra * Eigen::AngleAxisd(angle, axis).toRotationMatrix(),
                                       Eigen::Vector3d(4, 6, 3));
    const ev::PoseError e = ev::poseError(a, b);
    EXPECT_NEAR(e.angle, angle, 1e-12 * std::max(1.0, angle) + 1e-15) << angle;
    EXPECT_DOUBLE_EQ(e.distance, 5.0);
  }
}

TEST(Statistics, HandComputed)
{
  const ev::Statistics s = ev::computeStatistics({3, 1, 4, 1, 5});
  EXPECT_EQ(s.count, 5u);
  EXPECT_DOUBLE_EQ(s.mean, 2.8);
  EXPECT_DOUBLE_EQ(s.median, 3.0);
  EXPECT_DOUBLE_EQ(s.min, 1.0);
  EXPECT_DOUBLE_EQ(s.max, 5.0);
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(52.0 / 5.0));
  EXPECT_NEAR(s.std, 1.6, 1e-15); // population: sqrt(12.8 / 5)
  EXPECT_DOUBLE_EQ(ev::computeStatistics({4, 1, 3, 2}).median, 2.5);
  EXPECT_EQ(ev::computeStatistics({}).count, 0u);
}

TEST(PoseError, SummaryAndSizeMismatch)
{
  Poses a = line(4), b = line(4);
  b[2](1, 3) = 0.5;
  b[3](1, 3) = 1.0;
  const ev::PoseErrorSummary s = ev::summarizePoseErrors(a, b, 1);
  EXPECT_EQ(s.distance.count, 3u);
  EXPECT_DOUBLE_EQ(s.distance.max, 1.0);
  EXPECT_DOUBLE_EQ(s.distance.mean, 0.5);
  EXPECT_THROW(ev::summarizePoseErrors(a, line(3)), std::invalid_argument);
}

// ---------------------------------------------------------------- alignment, ATE

// Our Umeyama against Eigen's implementation of the same paper.
TEST(Umeyama, MatchesEigen)
{
  const Poses est = randomPoses(30, 7);
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(0.8, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.5);
  for (const bool with_scale : {false, true}) {
    Poses ref;
    Eigen::Matrix3Xd src(3, est.size()), dst(3, est.size());
    for (std::size_t i = 0; i < est.size(); ++i) {
      const Eigen::Vector3d p = 1.7 * r * est[i].topRightCorner<3, 1>() +
                                Eigen::Vector3d(3, 4, 5) +
                                Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      ref.push_back(makePose(Eigen::Matrix3d::Identity(), p));
      src.col(static_cast<Eigen::Index>(i)) = est[i].topRightCorner<3, 1>();
      dst.col(static_cast<Eigen::Index>(i)) = p;
    }
    const ev::Similarity s = ev::umeyamaAlignment(est, ref, with_scale);
    const Eigen::Matrix4d eigen = Eigen::umeyama(src, dst, with_scale);
    EXPECT_LT((s.scale * s.rotation - eigen.topLeftCorner<3, 3>()).norm(), 1e-10);
    EXPECT_LT((s.translation - eigen.topRightCorner<3, 1>()).norm(), 1e-9);
    EXPECT_NEAR(s.rotation.determinant(), 1.0, 1e-12);
    if (with_scale) {
      EXPECT_NEAR(s.scale, 1.7, 0.05);
    }
  }
}

TEST(Umeyama, DegenerateThrows)
{
  EXPECT_THROW(ev::umeyamaAlignment(line(10), line(10), false), std::invalid_argument);
  EXPECT_THROW(ev::umeyamaAlignment(line(1), line(1), false), std::invalid_argument);
  EXPECT_THROW(ev::umeyamaAlignment(line(3), line(4), false), std::invalid_argument);
}

TEST(Ate, IdenticalTrajectoriesGiveZero)
{
  const Poses gt = circle(40, 10.0);
  for (const ev::Alignment a : {ev::Alignment::None, ev::Alignment::SE3, ev::Alignment::Sim3}) {
    ev::EvaluationOptions o;
    o.alignment = a;
    const ev::TrajectoryEvaluation e = ev::evaluateTrajectory(gt, gt, o);
    EXPECT_LT(e.ate.translation.max, 1e-12);
    EXPECT_LT(e.ate.rotation_deg.max, 1e-9);
    EXPECT_LT(e.ate_unaligned.translation.max, 1e-15);
    EXPECT_TRUE(e.kitti.valid());
    EXPECT_LT(e.kitti.translation_percent, 1e-9);
    EXPECT_LT(e.kitti.rotation_deg_per_m, 1e-9);
    EXPECT_EQ(e.rpe.translation.count, 39u);
    EXPECT_LT(e.rpe.translation.max, 1e-12);
    EXPECT_LT(e.rpe.rotation_deg.max, 1e-9);
    EXPECT_NEAR(e.ate.similarity.scale, 1.0, 1e-12);
  }
}

// A whole trajectory moved rigidly: alignment removes it; unaligned, a pure translation
// (0.3, -0.4, 1.2) leaves |t| = 1.3 at every pose; relative errors are zero either way.
TEST(Ate, RigidOffsetIsRemovedByAlignment)
{
  const Poses gt = circle(40, 10.0);
  const Eigen::Matrix4d t = makePose(
      Eigen::AngleAxisd(40 * kDeg, Eigen::Vector3d(1, 1, 1).normalized()).toRotationMatrix(),
      Eigen::Vector3d(5, -3, 2));
  const Eigen::Matrix4d shift =
      makePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.3, -0.4, 1.2));
  Poses moved, shifted;
  for (const auto& p : gt) {
    moved.push_back(t * p);
    shifted.push_back(shift * p);
  }
  const ev::TrajectoryEvaluation e = ev::evaluateTrajectory(moved, gt);
  EXPECT_LT(e.ate.translation.max, 1e-9);
  EXPECT_LT(e.ate.rotation_deg.max, 1e-7);
  EXPECT_GT(e.ate_unaligned.translation.rmse, 1.0);
  EXPECT_LT(e.kitti.translation_percent, 1e-9);
  EXPECT_LT(e.rpe.translation.max, 1e-9);
  for (std::size_t i = 0; i < gt.size(); ++i)
    EXPECT_LT((e.ate.similarity.apply(moved[i]) - gt[i]).norm(), 1e-9);

  const ev::TrajectoryEvaluation s = ev::evaluateTrajectory(shifted, gt);
  EXPECT_LT(s.ate.translation.max, 1e-12);
  EXPECT_NEAR(s.ate_unaligned.translation.rmse, 1.3, 1e-12);
  EXPECT_NEAR(s.ate_unaligned.translation.min, 1.3, 1e-12);
  EXPECT_NEAR(s.ate_unaligned.translation.max, 1.3, 1e-12);
  EXPECT_LT(s.ate_unaligned.rotation_deg.max, 1e-12);
}

// The estimate at half scale: Sim(3) alignment finds scale 2 and removes everything; the
// rigid one cannot.
TEST(Ate, Sim3AlignmentRecoversScale)
{
  const Poses gt = circle(40, 10.0);
  Poses half;
  for (const auto& p : gt) {
    Eigen::Matrix4d q = p;
    q.topRightCorner<3, 1>() = 0.5 * p.topRightCorner<3, 1>() + Eigen::Vector3d(1, 2, 3);
    half.push_back(q);
  }
  ev::EvaluationOptions o;
  o.alignment = ev::Alignment::Sim3;
  const ev::TrajectoryEvaluation s = ev::evaluateTrajectory(half, gt, o);
  EXPECT_NEAR(s.ate.similarity.scale, 2.0, 1e-12);
  EXPECT_LT(s.ate.translation.max, 1e-9);
  EXPECT_LT(s.rpe.translation.max, 1e-9); // on the rescaled estimate
  const ev::TrajectoryEvaluation r = ev::evaluateTrajectory(half, gt);
  EXPECT_NEAR(r.ate.translation.rmse, 5.0, 1e-9); // radius 5 against 10, centred
}

// Known noise, chosen so the best alignment is the identity: on a circle of 40 poses
// (in the xy-plane), heights +a, -a, +b, -b, ... have zero mean and are uncorrelated with
// the positions (sum of c_i e^{i theta_i} = 0), so the alignment cannot absorb any of it:
// rmse = sqrt((a² + b²) / 2), mean = median = (a + b) / 2, std = |a - b| / 2. The same
// for orientations turned by +-0.01 rad about the local x axis.
TEST(Ate, KnownNoiseGivesKnownRmse)
{
  const double a = 0.03, b = 0.04, tilt = 0.01;
  const Poses gt = circle(40, 10.0);
  Poses noisy = gt;
  for (std::size_t i = 0; i < gt.size(); ++i) {
    const double sign = i % 2 ? -1.0 : 1.0;
    noisy[i](2, 3) += sign * (i % 4 < 2 ? a : b);
    noisy[i].topLeftCorner<3, 3>() *=
        Eigen::AngleAxisd(sign * tilt, Eigen::Vector3d::UnitX()).toRotationMatrix();
  }
  for (const ev::Alignment al : {ev::Alignment::None, ev::Alignment::SE3}) {
    const ev::AbsoluteError e = ev::absoluteTrajectoryError(noisy, gt, al);
    EXPECT_NEAR(e.translation.rmse, std::sqrt((a * a + b * b) / 2), 1e-9);
    EXPECT_NEAR(e.translation.mean, 0.035, 1e-9);
    EXPECT_NEAR(e.translation.median, 0.035, 1e-9);
    EXPECT_NEAR(e.translation.std, 0.005, 1e-9);
    EXPECT_NEAR(e.translation.min, a, 1e-9);
    EXPECT_NEAR(e.translation.max, b, 1e-9);
    EXPECT_NEAR(e.rotation_deg.rmse, tilt / kDeg, 1e-7);
  }
}

// ---------------------------------------------------------------- KITTI devkit RPE

// 1% scale drift on a straight 100 m path (poses 1 m apart). The devkit's segment from
// frame f for length L ends at the first frame MORE than L further, f + L + 1, so each
// segment's error is 0.01 (L + 1) / L: 1.1% (L = 10), 1.05% (20), 1.02% (50). Starts
// 0, 10, ..., 90 with f + L + 1 <= 100: 9, 8 and 5 segments; the mean over all 22 is
// (9 * 1.1 + 8 * 1.05 + 5 * 1.02) / 22 %.
TEST(KittiRpe, ScaleDriftGivesKnownPercent)
{
  const Poses gt = line(101);
  Poses est = gt;
  for (auto& p : est)
    p.topRightCorner<3, 1>() *= 1.01;
  const ev::KittiRelativeError k = ev::kittiRelativeError(est, gt, {10, 20, 50}, 10);
  ASSERT_EQ(k.segments.size(), 22u);
  EXPECT_EQ(k.segments[0].first_frame, 0u);
  EXPECT_EQ(k.segments[0].last_frame, 11u);
  ASSERT_EQ(k.per_length.size(), 3u);
  EXPECT_EQ(k.per_length[0].segments, 9u);
  EXPECT_EQ(k.per_length[1].segments, 8u);
  EXPECT_EQ(k.per_length[2].segments, 5u);
  EXPECT_NEAR(k.per_length[0].translation_percent, 1.1, 1e-9);
  EXPECT_NEAR(k.per_length[1].translation_percent, 1.05, 1e-9);
  EXPECT_NEAR(k.per_length[2].translation_percent, 1.02, 1e-9);
  EXPECT_NEAR(k.translation_percent, (9 * 1.1 + 8 * 1.05 + 5 * 1.02) / 22, 1e-9);
  EXPECT_LT(k.rotation_deg_per_m, 1e-12);
}

// Heading drift: positions exact, orientation of pose i turned by i·d about z. For a
// segment f -> l = f + k, est_rel = [Rz(k d) | Rz(-f d)(k, 0, 0)], gt_rel = [I | (k, 0, 0)],
// so E = est_rel⁻¹·gt_rel turns by k d and moves by |(k,0,0) - Rz(-f d)(k,0,0)| =
// 2 k sin(f d / 2): per segment k d / L rad/m and 2 k sin(f d / 2) / L.
TEST(KittiRpe, HeadingDriftGivesKnownDegPerMetre)
{
  const double d = 0.001;
  const Poses gt = line(101);
  Poses est = gt;
  for (std::size_t i = 0; i < est.size(); ++i)
    est[i].topLeftCorner<3, 3>() = rotZ(static_cast<double>(i) * d);
  const std::vector<double> lengths = {10, 20, 50};
  const ev::KittiRelativeError kr = ev::kittiRelativeError(est, gt, lengths, 10);
  double t_sum = 0, r_sum = 0;
  std::size_t n = 0;
  for (std::size_t f = 0; f <= 100; f += 10)
    for (const double len : lengths) {
      const double k = len + 1;
      if (f + static_cast<std::size_t>(k) > 100)
        continue;
      r_sum += k * d / len;
      t_sum += 2 * k * std::sin(static_cast<double>(f) * d / 2) / len;
      ++n;
    }
  ASSERT_EQ(kr.segments.size(), n);
  EXPECT_NEAR(kr.rotation_deg_per_m, r_sum / static_cast<double>(n) / kDeg, 1e-9);
  EXPECT_NEAR(kr.translation_percent, 100 * t_sum / static_cast<double>(n), 1e-9);
}

TEST(KittiRpe, LengthsForShortAndLongPaths)
{
  const std::vector<double> devkit = {100, 200, 300, 400, 500, 600, 700, 800};
  EXPECT_EQ(ev::kittiLengthsFor(line(1002)), devkit);                   // 1001 m
  const std::vector<double> short_path = ev::kittiLengthsFor(line(51)); // 50 m
  ASSERT_EQ(short_path.size(), 8u);
  for (int k = 1; k <= 8; ++k)
    EXPECT_NEAR(short_path[k - 1], 5.0 * k, 1e-12);
  EXPECT_TRUE(ev::kittiLengthsFor(line(1)).empty());
  // A path too short for any segment: no result rather than a made-up one.
  EXPECT_FALSE(ev::kittiRelativeError(line(5), line(5), {100}).valid());
}

// ---------------------------------------------------------------- evo's per-frame RPE

// Straight ground truth 1 m a step; the estimate steps 1.1 m and turns d a step. Pair
// (i, i+1): E = Q_rel⁻¹·P_rel = [Rz(d) | 1.1 Rz(-i d) x - x], so translation
// sqrt(1.21 + 1 - 2.2 cos(i d)), rotation d, point distance |1 - 1.1| = 0.1.
TEST(FrameRpe, HandComputed)
{
  const double d = 0.01;
  const Poses gt = line(11);
  Poses est;
  for (std::size_t i = 0; i < gt.size(); ++i)
    est.push_back(
        makePose(rotZ(static_cast<double>(i) * d), Eigen::Vector3d(1.1 * double(i), 0, 0)));
  for (const std::size_t delta : {1u, 2u}) {
    const double step = static_cast<double>(delta);
    std::vector<double> expected;
    for (std::size_t i = 0; i + delta < gt.size(); i += delta)
      expected.push_back(std::sqrt(1.21 * step * step + step * step -
                                   2.2 * step * step * std::cos(static_cast<double>(i) * d)));
    const ev::Statistics want = ev::computeStatistics(expected);
    const ev::FrameRelativeError r = ev::frameRelativeError(est, gt, delta);
    EXPECT_EQ(r.translation.count, 10u / delta);
    EXPECT_NEAR(r.translation.rmse, want.rmse, 1e-12);
    EXPECT_NEAR(r.translation.max, want.max, 1e-12);
    EXPECT_NEAR(r.rotation_deg.rmse, step * d / kDeg, 1e-9);
    EXPECT_NEAR(r.point_distance.rmse, 0.1 * step, 1e-12);
  }
}

// ---------------------------------------------------------------- association

TEST(Association, NearestTimestampWithinMaxDiffLikeEvo)
{
  using Pairs = std::vector<std::pair<std::size_t, std::size_t>>;
  // The estimate is shorter: each of its stamps looks for the nearest reference stamp;
  // 0.5 has none within 0.01 s.
  EXPECT_EQ(
      ev::associateByTimestamp({0.0, 0.1, 0.2, 0.305, 0.5}, {0.001, 0.1, 0.2, 0.3, 0.4, 0.6}),
      (Pairs{{0, 0}, {1, 1}, {2, 2}, {3, 3}}));
  // The estimate is longer: the reference's stamps look in it.
  EXPECT_EQ(ev::associateByTimestamp({0.0, 0.05, 0.1, 0.15, 0.2}, {0.052, 0.2}),
            (Pairs{{1, 0}, {4, 1}}));
  EXPECT_TRUE(ev::associateByTimestamp({0.0}, {1.0}).empty());
  EXPECT_THROW(ev::evaluateTrajectory(line(5), line(4)), std::invalid_argument);
}

// ---------------------------------------------------------------- pose files

// Two trajectories paired as `pcl_pslam evaluate` pairs them: by time stamp where both
// have them (the nearest within max_diff), else by index, the same length unless truncated.
TEST(Pairing, ByTimestampElseByIndex)
{
  auto at = [](double x) {
    Eigen::Matrix4d p = Eigen::Matrix4d::Identity();
    p(0, 3) = x;
    return p;
  };
  pio::Trajectory est, truth;
  est.poses = {at(0), at(1), at(2)};
  est.timestamps = {0.0, 1.0, 2.0};
  truth.poses = {at(10), at(11)};
  truth.timestamps = {1.004, 2.2};
  const auto timed = ev::pairTrajectories(est, "e", truth, "t", 0.01, false);
  ASSERT_EQ(timed.estimate.size(), 1u); // 2.0 and 2.2 lie 0.2 s apart
  EXPECT_EQ(timed.estimate[0](0, 3), 1.0);
  EXPECT_EQ(timed.truth[0](0, 3), 10.0);
  EXPECT_THROW(ev::pairTrajectories(est, "e", truth, "t", 1e-4, false), std::runtime_error);

  truth.timestamps.clear(); // by index: 3 against 2 poses
  try {
    ev::pairTrajectories(est, "est.txt", truth, "truth.txt", 0.01, false);
    FAIL() << "lengths differ";
  }
  catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("est.txt"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("truth.txt"), std::string::npos) << e.what();
  }
  const auto cut = ev::pairTrajectories(est, "e", truth, "t", 0.01, true);
  ASSERT_EQ(cut.estimate.size(), 2u);
  EXPECT_EQ(cut.estimate[1](0, 3), 1.0);
  EXPECT_EQ(cut.truth[1](0, 3), 11.0);
}

TEST(PoseFiles, KittiRoundTripIsExact)
{
  ScratchDir dir;
  const Poses poses = randomPoses(20, 1);
  pio::writeKittiPoses(dir / "poses.txt", poses);
  const Poses back = pio::loadKittiPoses(dir / "poses.txt");
  ASSERT_EQ(back.size(), poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i)
    EXPECT_EQ(back[i], poses[i]) << i; // shortest form that reads back exactly
  EXPECT_EQ(pio::detectPoseFileFormat(dir / "poses.txt"), pio::PoseFileFormat::Kitti);
  // Only the target is left (the temporary file was renamed).
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.str()),
                          std::filesystem::directory_iterator()),
            1);
}

TEST(PoseFiles, TumRoundTripKeepsTimestamps)
{
  ScratchDir dir;
  const Poses poses = randomPoses(20, 2);
  std::vector<double> stamps;
  for (std::size_t i = 0; i < poses.size(); ++i)
    stamps.push_back(1317384506.40 + 0.1 * static_cast<double>(i));
  pio::writeTumTrajectory(dir / "a.txt", poses, stamps);
  const pio::Trajectory t = pio::loadTrajectory(dir / "a.txt");
  EXPECT_EQ(t.format, pio::PoseFileFormat::Tum);
  EXPECT_EQ(t.timestamps, stamps);
  expectPosesNear(t.poses, poses, 1e-12);
  pio::writeTumTrajectory(dir / "b.tum", poses);
  const pio::Trajectory u = pio::loadTrajectory(dir / "b.tum");
  ASSERT_EQ(u.timestamps.size(), 20u);
  EXPECT_EQ(u.timestamps[7], 7.0);
  EXPECT_THROW(pio::writeTumTrajectory(dir / "c.txt", poses, {1.0}), std::invalid_argument);
}

TEST(PoseFiles, TumHandWritten)
{
  ScratchDir dir;
  const std::string path = dir.write("t.txt",
                                     "# timestamp tx ty tz qx qy qz qw\n"
                                     "\n"
                                     "1.5 1 2 3 0 0 0.70710678118654757 0.70710678118654757\n");
  const pio::Trajectory t = pio::loadTumTrajectory(path);
  ASSERT_EQ(t.poses.size(), 1u);
  EXPECT_EQ(t.timestamps[0], 1.5);
  EXPECT_LT((t.poses[0].topLeftCorner<3, 3>() - rotZ(M_PI / 2)).norm(), 1e-15);
  EXPECT_TRUE((t.poses[0].topRightCorner<3, 1>() == Eigen::Vector3d(1, 2, 3)));
}

// .frames: 3DTK's column-major matrix in centimetres; read back in metres, and as raw
// numbers by the existing reader (loadFramesFinalPose), which must agree.
TEST(PoseFiles, FramesRoundTripAndExistingReader)
{
  ScratchDir dir;
  const Poses history = randomPoses(3, 3);
  pio::writeFrames(dir / "scan000.frames", history);
  expectPosesNear(pio::loadFrames(dir / "scan000.frames"), history, 1e-12);
  const Eigen::Matrix4d raw = pio::loadFramesFinalPose(dir / "scan000.frames");
  EXPECT_LT((raw.topLeftCorner<3, 3>() - history.back().topLeftCorner<3, 3>()).norm(), 1e-15);
  EXPECT_LT((raw.topRightCorner<3, 1>() - 100.0 * history.back().topRightCorner<3, 1>()).norm(),
            1e-9);
  std::ifstream in(dir / "scan000.frames");
  std::string first;
  std::getline(in, first);
  EXPECT_EQ(first.substr(first.size() - 2), " 1"); // the type code (ICP)
}

TEST(PoseFiles, FramesDirectoryInScanNumberOrder)
{
  ScratchDir dir;
  const Poses poses = randomPoses(4, 4);
  pio::writeFramesDirectory(dir.str(), poses, pio::kFramesUnit, pio::kFramesLum, 998);
  for (const char* name :
       {"scan998.frames", "scan999.frames", "scan1000.frames", "scan1001.frames"})
    EXPECT_TRUE(std::filesystem::exists(dir / name)) << name;
  const pio::Trajectory t = pio::loadTrajectory(dir.str());
  EXPECT_EQ(t.format, pio::PoseFileFormat::Frames);
  EXPECT_TRUE(t.timestamps.empty());
  expectPosesNear(t.poses, poses, 1e-12); // scan1000 after scan999, not before scan998
}

TEST(PoseFiles, ReadsThe3dtkReferenceFrames)
{
  PCL_PARALLEL_REQUIRE_DATA(frames, "3dtk_dat/reference_frames_2009");
  const Poses poses = pio::loadFramesDirectory(frames);
  ASSERT_EQ(poses.size(), 3u);
  const Eigen::Matrix4d raw = pio::loadFramesFinalPose(frames + "/scan001.frames");
  EXPECT_TRUE((poses[1].topLeftCorner<3, 3>() == raw.topLeftCorner<3, 3>()));
  EXPECT_LT((poses[1].topRightCorner<3, 1>() - 0.01 * raw.topRightCorner<3, 1>()).norm(),
            1e-12);
}

/** The message holds the text (printed when not). */
#define EXPECT_HAS(message, text)                                                              \
  do {                                                                                         \
    const std::string m_ = (message);                                                          \
    EXPECT_NE(m_.find(text), std::string::npos) << "message: " << m_;                          \
  } while (0)

TEST(PoseFiles, BadFilesNameFileAndLine)
{
  ScratchDir dir;
  const std::string short_line = dir.write("short.txt", "0 0 0 0 0 0 0 1\n\n1 0 0 0 0 0 1\n");
  EXPECT_HAS(messageOf([&] { pio::loadTrajectory(short_line); }),
             "short.txt:3: expected 8 numbers");
  const std::string word = dir.write("word.txt", "0 0 0 0 0 0 0 1\n1 0 0 x 0 0 0 1\n");
  EXPECT_HAS(messageOf([&] { pio::loadTrajectory(word); }),
             "word.txt:2: column 4 is not a finite number: \"x\"");
  const std::string quat = dir.write("quat.txt", "0 0 0 0 0 0 0 2\n");
  EXPECT_HAS(messageOf([&] { pio::loadTrajectory(quat); }), "quat.txt:1: the quaternion");
  const std::string odd = dir.write("odd.txt", "# x y z\n1 2 3 4 5\n");
  EXPECT_HAS(messageOf([&] { pio::loadTrajectory(odd); }),
             "odd.txt:2: unknown pose file format: 5 fields");
  const std::string kitti =
      dir.write("k.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n");
  EXPECT_HAS(messageOf([&] { pio::loadTrajectory(kitti); }), "k.txt:2:");
  EXPECT_HAS(messageOf([&] { pio::loadTrajectory(dir / "missing.txt"); }),
             "missing.txt: no such file");
  EXPECT_HAS(messageOf([&] { pio::loadTrajectory(dir.write("empty.txt", "# nothing\n")); }),
             "empty.txt: holds no poses");
  std::filesystem::create_directory(dir / "frames");
  EXPECT_HAS(messageOf([&] { pio::loadTrajectory(dir / "frames"); }), "holds no .frames");
  const std::string frames = dir.write("frames/scan000.frames",
                                       "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 1\n"
                                       "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0\n");
  EXPECT_HAS(messageOf([&] { pio::loadTrajectory(dir / "frames"); }),
             "scan000.frames:2: expected 16 numbers");
  EXPECT_HAS(messageOf([&] { pio::loadTrajectory(frames); }), "pass the directory");
  EXPECT_HAS(messageOf([&] { pio::writeKittiPoses(dir / "no/such/dir/p.txt", line(2)); }),
             "p.txt: cannot open for writing");
  // A non-finite pose is refused before any file exists (no NaN in an output).
  auto bad = line(3);
  bad[1](2, 3) = std::nan("");
  for (const char* name : {"nan.txt", "nan.tum", "nan.frames"}) {
    const auto path = dir / name;
    EXPECT_THROW(std::string(name) == "nan.txt"   ? pio::writeKittiPoses(path, bad)
                 : std::string(name) == "nan.tum" ? pio::writeTumTrajectory(path, bad)
                                                  : pio::writeFrames(path, bad),
                 std::invalid_argument);
    EXPECT_FALSE(std::filesystem::exists(path)) << name;
  }
}

// Fuzz-stage findings (fuzz_frames_history, fuzz_frames_dir; scripts/test.sh fuzz), kept
// as regressions: the two .frames readers (pose_files.h loadFrames, uos.h
// loadFramesFinalPose) accepted a last row other than 0 0 0 1 (not a rigid motion), and
// disagreed on commas between numbers, on "+-1" and on a non-finite type code.
TEST(PoseFiles, FuzzFindingsFramesReadersAgree)
{
  ScratchDir dir;
  const std::string row =
      dir.write("row.frames",
                "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 2\n"
                "0.99 0.01 0 0 -0.01 0.99 0 0 0 0 1 0 12.5 -3 337.79 2 1\n");
  EXPECT_HAS(messageOf([&] { pio::loadFrames(row); }), "row.frames:2: columns 4, 8, 12, 16");
  EXPECT_HAS(messageOf([&] { pio::loadFramesFinalPose(row); }),
             "row.frames:2: columns 4, 8, 12, 16");
  // Rounding left by a writer is tolerated, and the row set exactly.
  const std::string rounded =
      dir.write("rounded.frames", "1 0 0 1e-12 0 1 0 0 0 0 1 0 1 2 3 0.9999999999997 2\n");
  EXPECT_EQ(pio::loadFrames(rounded, 1.0).back().row(3), Eigen::RowVector4d(0, 0, 0, 1));
  EXPECT_EQ(pio::loadFramesFinalPose(rounded).row(3), Eigen::RowVector4d(0, 0, 0, 1));
  const std::string plus_minus =
      dir.write("pm.frames", "+-1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 2\n");
  EXPECT_HAS(messageOf([&] { pio::loadFrames(plus_minus); }), "pm.frames:1: column 1");
  EXPECT_HAS(messageOf([&] { pio::loadFramesFinalPose(plus_minus); }), "pm.frames:1:");
  const std::string type = dir.write("type.frames", "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 nan\n");
  EXPECT_HAS(messageOf([&] { pio::loadFrames(type); }), "type.frames:1: column 17");
  EXPECT_HAS(messageOf([&] { pio::loadFramesFinalPose(type); }), "type.frames:1:");
  // Commas separate numbers in every text format (as KITTI poses and .xyz), read alike.
  const std::string commas =
      dir.write("commas.frames", "\t1 0 0 0, 0 1 0 0 ,0 0 1 0,0.5,1 , -3 1 2\n");
  Eigen::Matrix4d expected = Eigen::Matrix4d::Identity();
  expected.topRightCorner<3, 1>() << 0.5, 1, -3;
  EXPECT_EQ(pio::loadFrames(commas, 1.0).back(), expected);
  EXPECT_EQ(pio::loadFramesFinalPose(commas), expected);
  const std::string tum = dir.write("commas.tum", "1.5, 1, 2, 3, 0, 0, 0, 1\n");
  const Eigen::Vector3d t = pio::loadTumTrajectory(tum).poses.at(0).topRightCorner<3, 1>();
  EXPECT_EQ(t, Eigen::Vector3d(1, 2, 3));
}

// KITTI's times.txt (read by `pcl_pslam run`): the text formats' one number parser (no
// locale, "+" allowed), errors with file and line and a short quote of binary garbage.
TEST(PoseFiles, KittiTimes)
{
  ScratchDir dir;
  const std::string good = dir.write("times.txt", "0.000000e+00\n\n1.036594e-01\r\n  +2.5 \n");
  EXPECT_EQ(pio::loadKittiTimes(good), (std::vector<double>{0.0, 1.036594e-01, 2.5}));
  EXPECT_HAS(messageOf([&] { pio::loadKittiTimes(dir.write("two.txt", "1\n2 3\n")); }),
             "two.txt:2: expected 1 numbers");
  EXPECT_HAS(messageOf([&] { pio::loadKittiTimes(dir.write("nan.txt", "1\nnan\n")); }),
             "nan.txt:2: column 1 is not a finite number");
  EXPECT_HAS(messageOf([&] { pio::loadKittiTimes(dir.write("comma.txt", "0,5\n")); }),
             "comma.txt:1: expected 1 numbers");
  const std::string garbage = dir.write("garbage.txt", std::string(5000, '\xff'));
  const std::string message = messageOf([&] { pio::loadKittiTimes(garbage); });
  EXPECT_HAS(message, "garbage.txt:1: column 1 is not a finite number: \"\\xff");
  EXPECT_LT(message.size(), garbage.size() + 250) << message;
  EXPECT_HAS(messageOf([&] { pio::loadKittiTimes(dir / "missing.txt"); }),
             "missing.txt: no such");
}

// `pcl_pslam evaluate`'s library face: the files read, paired and evaluated as the
// structure, and the table printed from that same structure.
TEST(FileEvaluation, StructureIsWhatThePairedPosesGiveAndWhatIsPrinted)
{
  ScratchDir dir;
  const Poses truth = randomPoses(40, 11);
  Poses est = truth;
  for (std::size_t i = 0; i < est.size(); ++i)
    est[i].topRightCorner<3, 1>() += Eigen::Vector3d(0.01 * i, -0.02, 0.005 * (i % 3));
  std::vector<double> stamps;
  for (std::size_t i = 0; i < est.size(); ++i)
    stamps.push_back(0.1 * static_cast<double>(i));
  pio::writeTumTrajectory(dir / "est.tum", est, stamps);
  pio::writeKittiPoses(dir / "truth.txt", truth);
  ev::FileEvaluationOptions options;
  options.evaluation.alignment = ev::Alignment::None;
  options.evaluation.kitti_lengths = {5.0, 10.0};
  const ev::FileEvaluation e = ev::evaluateFiles(dir / "est.tum", dir / "truth.txt", options);
  EXPECT_EQ(e.estimate.format, pio::PoseFileFormat::Tum);
  EXPECT_EQ(e.truth.format, pio::PoseFileFormat::Kitti);
  EXPECT_EQ(e.association, "by index: only one file has timestamps");
  const ev::TrajectoryEvaluation direct =
      ev::evaluateTrajectory(e.estimate.poses, truth, options.evaluation);
  EXPECT_EQ(e.errors.poses, 40u);
  EXPECT_EQ(e.errors.ate.translation.rmse, direct.ate.translation.rmse);
  EXPECT_EQ(e.errors.kitti.lengths, (std::vector<double>{5.0, 10.0}));
  EXPECT_GT(e.errors.ate.translation.rmse, 0.05);

  std::ostringstream out, table;
  ev::printFileEvaluation(out, e);
  ev::printEvaluation(table, e.errors);
  const std::string text = out.str();
  EXPECT_EQ(text.find("estimate      " + ev::describe(dir / "est.tum", e.estimate) + "\n"), 0u)
      << text;
  EXPECT_HAS(text, "paired        by index: only one file has timestamps\n");
  EXPECT_EQ(text.substr(text.size() - table.str().size()), table.str());
  EXPECT_EQ(out.precision(), std::ostringstream().precision()); // the stream's state kept

  // By time stamp where both have them; a broken pose is named by its file.
  pio::writeTumTrajectory(dir / "truth.tum", truth, stamps);
  EXPECT_HAS(ev::evaluateFiles(dir / "est.tum", dir / "truth.tum", options).association,
             "by timestamp");
  Poses bad = truth;
  bad[3](0, 0) = 2.0;
  pio::writeKittiPoses(dir / "bad.txt", bad);
  EXPECT_HAS(messageOf([&] { ev::evaluateFiles(dir / "est.tum", dir / "bad.txt"); }),
             "bad.txt");
}

// `evaluate --json`: every number the structure holds, under its name, and null (not a
// number) for a KITTI rate no segment gives.
TEST(FileEvaluation, JsonHoldsTheStructuresNumbers)
{
  ScratchDir dir;
  const Poses truth = randomPoses(30, 5);
  Poses est = truth;
  for (std::size_t i = 0; i < est.size(); ++i)
    est[i].topRightCorner<3, 1>() += Eigen::Vector3d(0.02 * i, 0.01, -0.003 * (i % 4));
  pio::writeKittiPoses(dir / "est.txt", est);
  pio::writeKittiPoses(dir / "truth.txt", truth);
  ev::FileEvaluationOptions options;
  options.evaluation.alignment = ev::Alignment::Sim3;
  options.evaluation.kitti_lengths = {2.0, 1e6}; // the second fits no segment
  const ev::FileEvaluation e = ev::evaluateFiles(dir / "est.txt", dir / "truth.txt", options);
  const std::string text = ev::toJson(e);
  EXPECT_EQ(text.rfind("{\n  \"association\": \"by index", 0), 0u) << text; // indented by 2
  EXPECT_EQ(ev::toJson(e, -1).find('\n'), std::string::npos);
  const nlohmann::json j = nlohmann::json::parse(text);
  const ev::TrajectoryEvaluation& t = e.errors;
  EXPECT_EQ(j["poses"], t.poses);
  EXPECT_EQ(j["path_length_m"], t.reference_path_length);
  EXPECT_EQ(j["association"].get<std::string>(), e.association);
  EXPECT_EQ(j["ate"]["alignment"], "sim3");
  EXPECT_EQ(j["ate"]["scale"], t.ate.similarity.scale);
  EXPECT_EQ(j["ate_unaligned"]["alignment"].get<std::string>(),
            ev::toString(t.ate_unaligned.alignment));
  const auto expectStats = [](const nlohmann::json& js, const ev::Statistics& s) {
    EXPECT_EQ(js["count"], s.count);
    EXPECT_EQ(js["rmse"], s.rmse);
    EXPECT_EQ(js["mean"], s.mean);
    EXPECT_EQ(js["median"], s.median);
    EXPECT_EQ(js["std"], s.std);
    EXPECT_EQ(js["min"], s.min);
    EXPECT_EQ(js["max"], s.max);
  };
  expectStats(j["ate"]["translation_m"], t.ate.translation);
  expectStats(j["ate"]["rotation_deg"], t.ate.rotation_deg);
  expectStats(j["ate_unaligned"]["translation_m"], t.ate_unaligned.translation);
  expectStats(j["rpe_frame"]["translation_m"], t.rpe.translation);
  expectStats(j["rpe_frame"]["rotation_deg"], t.rpe.rotation_deg);
  expectStats(j["rpe_frame"]["point_distance_m"], t.rpe.point_distance);
  EXPECT_EQ(j["rpe_frame"]["delta_frames"], t.rpe.delta);
  const nlohmann::json& k = j["rpe_kitti"];
  ASSERT_TRUE(t.kitti.valid());
  EXPECT_EQ(k["translation_percent"], t.kitti.translation_percent);
  EXPECT_EQ(k["rotation_deg_per_m"], t.kitti.rotation_deg_per_m);
  EXPECT_EQ(k["segments"], t.kitti.segments.size());
  EXPECT_EQ(k["step_frames"], t.kitti.step);
  EXPECT_EQ(k["lengths_m"].get<std::vector<double>>(), t.kitti.lengths);
  ASSERT_EQ(k["per_length"].size(), 2u);
  EXPECT_EQ(k["per_length"][0]["segments"], t.kitti.per_length[0].segments);
  EXPECT_EQ(k["per_length"][0]["translation_percent"],
            t.kitti.per_length[0].translation_percent);
  EXPECT_EQ(k["per_length"][1]["segments"], 0);
  EXPECT_TRUE(k["per_length"][1]["translation_percent"].is_null());
  EXPECT_TRUE(k["per_length"][1]["rotation_deg_per_m"].is_null());
  EXPECT_EQ(j["estimate"]["path"].get<std::string>(), std::string(dir / "est.txt"));
  EXPECT_EQ(j["estimate"]["format"], "kitti");
  EXPECT_EQ(j["estimate"]["poses"], 30);
  EXPECT_EQ(j["ground_truth"]["timestamps"], false);
}

// The run summary's table: a header and a line per trajectory, in fixed columns whatever
// the stream's own format.
TEST(FileEvaluation, ErrorRowsInFixedColumns)
{
  ev::NamedEvaluation a{"front end", {}}, b{"final", {}};
  a.errors.ate.translation.rmse = 1.23456;
  a.errors.ate.rotation_deg.rmse = 2.5;
  a.errors.kitti.translation_percent = 3.25;
  a.errors.kitti.rotation_deg_per_m = 0.012345;
  a.errors.rpe.translation.rmse = 0.5;
  b.errors.ate.translation.rmse = 10.0;
  std::ostringstream out;
  out << std::scientific << std::setprecision(1);
  ev::printErrorRows(out, {a, b});
  EXPECT_EQ(out.str(),
            "                ATE [m]  ATE [deg]   RPE [%] RPE [deg/m] frame RPE [m]\n"
            "  front end      1.2346      2.500     3.250    0.01235       0.5000\n"
            "  final         10.0000      0.000     0.000    0.00000       0.0000\n");
}

// A run's rows against the truth: the odometry's only where there is one, each row the
// trajectory's own evaluation.
TEST(FileEvaluation, RunRowsAreTheTrajectoriesEvaluations)
{
  ev::Poses truth, drifted;
  for (int i = 0; i < 30; ++i) {
    Eigen::Matrix4d p = Eigen::Matrix4d::Identity();
    p(0, 3) = i, p(1, 3) = 0.1 * std::sin(0.3 * i);
    truth.push_back(p);
    p(1, 3) += 0.002 * i * i; // a bend SE(3) alignment cannot take out
    drifted.push_back(p);
  }
  const auto rows = ev::evaluateRun({}, drifted, truth, truth);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].name, "front end");
  EXPECT_EQ(rows[1].name, "final");
  EXPECT_EQ(rows[0].errors.ate.translation.rmse,
            ev::evaluateTrajectory(drifted, truth).ate.translation.rmse);
  EXPECT_GT(rows[0].errors.ate.translation.rmse, 1e-3);
  EXPECT_LT(rows[1].errors.ate.translation.rmse, 1e-9);
  const auto with_odometry = ev::evaluateRun(drifted, truth, truth, truth);
  ASSERT_EQ(with_odometry.size(), 3u);
  EXPECT_EQ(with_odometry[0].name, "odometry");
}

TEST(FileEvaluation, KittiLengthsFromText)
{
  EXPECT_TRUE(ev::kittiLengthsFromString("auto").empty());
  EXPECT_EQ(ev::kittiLengthsFromString("kitti"), ev::kittiDefaultLengths());
  EXPECT_EQ(ev::kittiLengthsFromString("10,2.5,40"), (std::vector<double>{10.0, 2.5, 40.0}));
  for (const char* bad : {"", "10,-1", "10,x", "nan", "0", "10 m"})
    EXPECT_THROW(ev::kittiLengthsFromString(bad), std::invalid_argument) << bad;
}

} // namespace

namespace {

/** Relation lines "t1 t2 x y z roll pitch yaw" of the truth's motions between stamps i
 *  and j (stamps are 100 + i / 10 s). */
std::vector<ev::Relation>
relationsOf(const Poses& truth, const std::vector<std::pair<std::size_t, std::size_t>>& pairs)
{
  std::vector<ev::Relation> relations;
  for (const auto& [i, j] : pairs) {
    ev::Relation r;
    r.t1 = 100.0 + 0.1 * static_cast<double>(i);
    r.t2 = 100.0 + 0.1 * static_cast<double>(j);
    r.motion = truth[i].inverse() * truth[j];
    relations.push_back(r);
  }
  return relations;
}

std::vector<double>
stampsOf(std::size_t n)
{
  std::vector<double> stamps;
  for (std::size_t i = 0; i < n; ++i)
    stamps.push_back(100.0 + 0.1 * static_cast<double>(i));
  return stamps;
}

} // namespace

// The relation file's format (the Freiburg benchmark's): t1 t2 x y z roll pitch yaw,
// R = Rz(yaw) Ry(pitch) Rx(roll); comments and blank lines skipped.
TEST(Relations, ReadsTheFreiburgFormat)
{
  ScratchDir dir;
  const auto path = dir.write("a.relations",
                              "# t1 t2 x y z roll pitch yaw\n\n"
                              "1185.029675 1185.237675 0.055262 -0.000206 0 0 0 0.001014\n"
                              "10 20 1 2 3 0.1 0.2 0.3\n");
  const auto r = ev::loadRelations(path);
  ASSERT_EQ(r.size(), 2u);
  EXPECT_EQ(r[0].line, 3u);
  EXPECT_DOUBLE_EQ(r[0].t1, 1185.029675);
  EXPECT_DOUBLE_EQ(r[0].t2, 1185.237675);
  EXPECT_DOUBLE_EQ(r[0].motion(0, 3), 0.055262);
  EXPECT_NEAR(std::atan2(r[0].motion(1, 0), r[0].motion(0, 0)), 0.001014, 1e-15);
  const Eigen::Matrix3d expected = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()))
                                       .toRotationMatrix();
  EXPECT_TRUE((r[1].motion.topLeftCorner<3, 3>().isApprox(expected, 1e-14)));
  EXPECT_EQ((r[1].motion.topRightCorner<3, 1>()), Eigen::Vector3d(1, 2, 3));
}

TEST(Relations, BadFilesNameFileAndLine)
{
  ScratchDir dir;
  const auto errorOf = [&](const std::string& name, const std::string& text) {
    return messageOf<std::runtime_error>([&] { ev::loadRelations(dir.write(name, text)); });
  };
  EXPECT_NE(errorOf("short.relations", "1 2 0 0 0 0 0 0\n1 2 3 4 5 6 7\n")
                .find("short.relations:2: expected 8 numbers"),
            std::string::npos);
  EXPECT_NE(
      errorOf("long.relations", "1 2 0 0 0 0 0 0 9\n").find("long.relations:1: more than 8"),
      std::string::npos);
  EXPECT_NE(errorOf("nan.relations", "\n1 2 0 nan 0 0 0 0\n")
                .find("nan.relations:2: column 4 is not a finite number"),
            std::string::npos);
  EXPECT_NE(errorOf("text.relations", "1 2 0 0 0 0 0 zero\n")
                .find("text.relations:1: column 8 is not a finite number: \"zero\""),
            std::string::npos);
  EXPECT_NE(
      errorOf("empty.relations", "# nothing\n").find("empty.relations: holds no relation"),
      std::string::npos);
  EXPECT_THROW(ev::loadRelations(dir / "missing.relations"), std::runtime_error);
}

// The truth's own motions: every error 0; only relations whose two times both lie within
// max_diff of a pose are used.
TEST(Relations, PerfectTrajectoryGivesZeroAndUnmatchedAreCounted)
{
  const Poses truth = circle(20, 5.0);
  auto relations = relationsOf(truth, {{0, 1}, {3, 9}, {19, 2}, {5, 5}});
  relations.push_back(relations[0]);
  relations.back().t2 = 100.105; // between two stamps, 5 ms from 100.1 and 100.2
  relations.push_back(relations[0]);
  relations.back().t1 = 99.0; // before the trajectory
  const ev::RelationError e = ev::relationError(stampsOf(20), truth, relations, 0.004);
  EXPECT_EQ(e.relations, 6u);
  EXPECT_EQ(e.used, 4u);
  EXPECT_EQ(e.unmatched, 2u);
  for (const ev::MeanStd& m :
       {e.translation, e.translation_squared, e.rotation, e.rotation_squared}) {
    EXPECT_NEAR(m.mean, 0.0, 1e-6);
    EXPECT_NEAR(m.std, 0.0, 1e-6);
  }
  EXPECT_EQ(ev::relationError(stampsOf(20), truth, relations, 0.006).used, 5u);
  EXPECT_THROW(ev::relationError(stampsOf(19), truth, relations), std::invalid_argument);
}

// A constant heading bias b on every pose (x_i·Rz(b)) turns each measured step t into
// Rz(-b)·t: translation error |Rz(-b)t - t| = 2|t| sin(b/2), rotation error 0. A bias
// growing by b per pose (x_i·Rz(i b)) on poses at one place: rotation error |j - i|·b.
TEST(Relations, KnownRotationBiasGivesTheHandComputedNumbers)
{
  constexpr double b = 10.0 * kDeg;
  Poses line, biased;
  for (int i = 0; i < 5; ++i) {
    line.push_back(makePose(Eigen::Matrix3d::Identity(), Eigen::Vector3d(i, 0, 0)));
    biased.push_back(line.back() * makePose(rotZ(b), Eigen::Vector3d::Zero()));
  }
  const auto steps = relationsOf(line, {{0, 1}, {1, 2}, {2, 4}});
  ev::RelationError e = ev::relationError(stampsOf(5), biased, steps);
  ASSERT_EQ(e.used, 3u);
  const double one = 2.0 * std::sin(b / 2.0); // steps of 1, 1, 2 m
  EXPECT_NEAR(e.translation.mean, 4.0 * one / 3.0, 1e-12);
  EXPECT_NEAR(e.translation.std, one / std::sqrt(3.0), 1e-12); // sample std of 1, 1, 2
  EXPECT_NEAR(e.translation_squared.mean, 2.0 * one * one, 1e-12);
  EXPECT_NEAR(e.translation_squared.std, std::sqrt(3.0) * one * one, 1e-12); // of 1, 1, 4
  EXPECT_NEAR(e.rotation.mean, 0.0, 1e-9);

  Poses still, turning;
  for (int i = 0; i < 6; ++i) {
    still.push_back(Eigen::Matrix4d::Identity());
    turning.push_back(makePose(rotZ(i * 1.0 * kDeg), Eigen::Vector3d::Zero()));
  }
  e = ev::relationError(stampsOf(6), turning, relationsOf(still, {{0, 1}, {1, 3}, {2, 5}}));
  ASSERT_EQ(e.used, 3u);
  EXPECT_NEAR(e.translation.mean, 0.0, 1e-12);
  EXPECT_NEAR(e.rotation.mean, 2.0, 1e-9); // 1, 2, 3 degrees
  EXPECT_NEAR(e.rotation.std, 1.0, 1e-9);
  EXPECT_NEAR(e.rotation_squared.mean, 14.0 / 3.0, 1e-9); // 1, 4, 9 deg²
  EXPECT_NEAR(e.rotation_squared.std, std::sqrt(49.0 / 3.0), 1e-9);
  ASSERT_EQ(e.rotation_deg.size(), 3u);
  EXPECT_NEAR(e.rotation_deg[2], 3.0, 1e-9);
}

// Through the files: the trajectory must have time stamps, and a relations file whose
// times match none of them is an error (no score from no relation).
TEST(Relations, FileEvaluationNeedsStampsAndAMatch)
{
  ScratchDir dir;
  const Poses truth = circle(10, 3.0);
  pio::writeTumTrajectory(dir / "est.tum", truth, stampsOf(10));
  pio::writeKittiPoses(dir / "est.kitti", truth);
  std::ostringstream rel;
  rel << std::setprecision(17) << "100 100.5 " << (truth[0].inverse() * truth[5])(0, 3) << ' '
      << (truth[0].inverse() * truth[5])(1, 3) << " 0 0 0 " << 0.5 * 2.0 * M_PI << '\n';
  const auto relations = dir.write("r.relations", rel.str());
  const ev::RelationFileEvaluation f =
      ev::evaluateRelationsFile(dir / "est.tum", relations, 0.01);
  EXPECT_EQ(f.errors.used, 1u);
  EXPECT_NEAR(f.errors.translation.mean, 0.0, 1e-9);
  EXPECT_NEAR(f.errors.rotation.mean, 0.0, 1e-9);
  std::ostringstream table;
  ev::printRelationEvaluation(table, f);
  EXPECT_NE(table.str().find("matched       1 relations by timestamp"), std::string::npos)
      << table.str();
  const auto j = nlohmann::json::parse(ev::toJson(f));
  EXPECT_EQ(j["used"], 1);
  EXPECT_EQ(j["unmatched"], 0);
  EXPECT_NEAR(j["rotation_deg"]["mean"].get<double>(), 0.0, 1e-9);
  EXPECT_THROW(ev::evaluateRelationsFile(dir / "est.kitti", relations), std::runtime_error);
  const auto far = dir.write("far.relations", "5 6 0 0 0 0 0 0\n");
  try {
    ev::evaluateRelationsFile(dir / "est.tum", far);
    ADD_FAILURE() << "no exception";
  }
  catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no relation of " + far), std::string::npos)
        << e.what();
  }
}
