/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * `pcl_pslam evaluate` (apps/pcl_pslam/evaluate_command.h) on files written here: the JSON
 * parses and holds the known answers, the formats round-trip through it, errors come with
 * the right exit code and name the file and line.
 */
#include "evaluate_command.h"
#include "scratch_dir.h"

#include <pcl_parallel/evaluation/trajectory_error.h>
#include <pcl_parallel/io/pose_files.h>

#include <Eigen/Geometry>

#include <cmath>
#include <fstream>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sstream>

namespace {

namespace pio = pcl_parallel::io;
using pcl_parallel::test::ScratchDir;
namespace ev = pcl_parallel::evaluation;
using Poses = std::vector<Eigen::Matrix4d>;

/** 40 poses on a circle of radius 10 m (a path of ~62 m). */
Poses
circle()
{
  Poses p;
  for (int i = 0; i < 40; ++i) {
    const double a = 2.0 * M_PI * i / 40.0;
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() =
        Eigen::AngleAxisd(a + M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    m.topRightCorner<3, 1>() = Eigen::Vector3d(10 * std::cos(a), 10 * std::sin(a), 0);
    p.push_back(m);
  }
  return p;
}

/** The circle with heights +a, -a, +b, -b, ... (see test_evaluation's KnownNoise test:
 *  the alignment cannot absorb them, ATE rmse = sqrt((a² + b²) / 2)). */
Poses
noisyCircle(double a, double b)
{
  Poses p = circle();
  for (std::size_t i = 0; i < p.size(); ++i)
    p[i](2, 3) += (i % 2 ? -1.0 : 1.0) * (i % 4 < 2 ? a : b);
  return p;
}

struct Outcome {
  int code;
  std::string out, err;
};

Outcome
evaluate(const std::vector<std::string>& args)
{
  std::ostringstream out, err;
  const int code = pcl_pslam::evaluateCommand(args, out, err);
  return {code, out.str(), err.str()};
}

#define EXPECT_HAS(message, text)                                                              \
  do {                                                                                         \
    const std::string m_ = (message);                                                          \
    EXPECT_NE(m_.find(text), std::string::npos) << "message: " << m_;                          \
  } while (0)

// KITTI estimate against TUM ground truth (no common timestamps: paired by index).
TEST(EvaluateCommand, JsonHoldsTheKnownAnswer)
{
  ScratchDir dir;
  pio::writeKittiPoses(dir / "est.txt", noisyCircle(0.03, 0.04));
  pio::writeTumTrajectory(dir / "gt.txt", circle());
  const Outcome r = evaluate({dir / "est.txt", dir / "gt.txt", "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(
      j["ate"]["translation_m"]["rmse"].get<double>(), std::sqrt((0.0009 + 0.0016) / 2), 1e-9);
  EXPECT_EQ(j["ate"]["alignment"], "se3");
  EXPECT_EQ(j["ate"]["translation_m"]["count"], 40);
  EXPECT_EQ(j["estimate"]["format"], "kitti");
  EXPECT_EQ(j["ground_truth"]["format"], "tum");
  EXPECT_EQ(j["rpe_frame"]["translation_m"]["count"], 39);
  EXPECT_EQ(j["rpe_kitti"]["lengths_m"].size(), 8u); // 10%..80% of a ~62 m path
  EXPECT_TRUE(j["rpe_kitti"]["translation_percent"].is_number());
  EXPECT_HAS(j["association"].get<std::string>(), "by index");
}

// Every format through `evaluate`: the same trajectory written as KITTI, TUM and .frames
// evaluates to zero against each of the others.
TEST(EvaluateCommand, FormatsRoundTrip)
{
  ScratchDir dir;
  const Poses p = noisyCircle(0.02, 0.05);
  pio::writeKittiPoses(dir / "p.kitti", p);
  pio::writeTumTrajectory(dir / "p.tum", p);
  std::filesystem::create_directory(dir / "frames");
  pio::writeFramesDirectory(dir / "frames", p);
  const std::vector<std::string> files = {dir / "p.kitti", dir / "p.tum", dir / "frames"};
  for (const auto& a : files)
    for (const auto& b : files) {
      const Outcome r = evaluate({a, b, "--json", "--align", "none"});
      ASSERT_EQ(r.code, 0) << a << " vs " << b << ": " << r.err;
      const nlohmann::json j = nlohmann::json::parse(r.out);
      EXPECT_LT(j["ate"]["translation_m"]["max"].get<double>(), 1e-9) << a << " vs " << b;
      EXPECT_LT(j["ate"]["rotation_deg"]["max"].get<double>(), 1e-6) << a << " vs " << b;
    }
}

// Both TUM with timestamps: paired by time, so a ground truth at twice the rate with an
// extra pose matches the estimate's 40 poses.
TEST(EvaluateCommand, PairsByTimestamp)
{
  ScratchDir dir;
  const Poses p = circle();
  std::vector<double> est_t, gt_t;
  Poses gt;
  for (std::size_t i = 0; i < p.size(); ++i) {
    est_t.push_back(100.0 + static_cast<double>(i) + 0.004);
    gt_t.push_back(100.0 + static_cast<double>(i));
    gt.push_back(p[i]);
    gt_t.push_back(100.5 + static_cast<double>(i)); // between: a pose far away
    gt.push_back(Eigen::Matrix4d::Identity());
  }
  pio::writeTumTrajectory(dir / "est.txt", p, est_t);
  pio::writeTumTrajectory(dir / "gt.txt", gt, gt_t);
  const Outcome r = evaluate({dir / "est.txt", dir / "gt.txt", "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["ate"]["translation_m"]["count"], 40);
  EXPECT_LT(j["ate"]["translation_m"]["max"].get<double>(), 1e-9);
  EXPECT_HAS(j["association"].get<std::string>(), "by timestamp");
  // Stamps 0.004 s apart do not pair with --max-diff 0.001: no pair at all is bad data.
  const Outcome none = evaluate({dir / "est.txt", dir / "gt.txt", "--max-diff", "0.001"});
  EXPECT_EQ(none.code, 1);
  EXPECT_HAS(none.err, "no timestamps");
}

TEST(EvaluateCommand, MismatchedLengthsAreAnErrorUnlessTruncated)
{
  ScratchDir dir;
  Poses p = circle();
  pio::writeKittiPoses(dir / "gt.txt", p);
  p.pop_back();
  pio::writeKittiPoses(dir / "est.txt", p);
  const Outcome r = evaluate({dir / "est.txt", dir / "gt.txt"});
  EXPECT_EQ(r.code, 1);
  EXPECT_HAS(r.err, "has 39 poses");
  const Outcome t = evaluate({dir / "est.txt", dir / "gt.txt", "--truncate"});
  ASSERT_EQ(t.code, 0) << t.err;
  EXPECT_HAS(t.out, "truncated to the first 39");
  EXPECT_HAS(t.out, "ATE (se3 alignment)");
}

// A straight path cannot be aligned (the rotation about it is free): an error that says
// what to do, as evo refuses too; without alignment it evaluates.
TEST(EvaluateCommand, StraightPathNeedsNoAlignment)
{
  ScratchDir dir;
  Poses p;
  for (int i = 0; i < 30; ++i) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m(0, 3) = i;
    p.push_back(m);
  }
  pio::writeKittiPoses(dir / "gt.txt", p);
  const Outcome r = evaluate({dir / "gt.txt", dir / "gt.txt"});
  EXPECT_EQ(r.code, 1);
  EXPECT_HAS(r.err, "--align none");
  const Outcome n = evaluate({dir / "gt.txt", dir / "gt.txt", "--align", "none", "--json"});
  ASSERT_EQ(n.code, 0) << n.err;
  // 29 m: lengths 2.9, 5.8, ..., 23.2 m; from frame 0 all 8 fit, from 10 those below 19 m
  // (6), from 20 those below 9 m (3).
  EXPECT_EQ(nlohmann::json::parse(n.out)["rpe_kitti"]["segments"], 17);
}

TEST(EvaluateCommand, BadDataExitsOneNamingFileAndLine)
{
  ScratchDir dir;
  pio::writeKittiPoses(dir / "gt.txt", circle());
  const std::string bad =
      dir.write("est.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 oops\n");
  const Outcome r = evaluate({bad, dir / "gt.txt"});
  EXPECT_EQ(r.code, 1);
  EXPECT_HAS(r.err, "est.txt:2:");
  EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << "one line: " << r.err;
  EXPECT_EQ(evaluate({dir / "none.txt", dir / "gt.txt"}).code,
            2); // usage, as run's missing DIR
}

// Fuzz-stage finding (fuzz_evaluate): a KITTI line is any 12 finite numbers; a rotation
// entry of 7.7e80 made the per-frame RPE inf, printed with exit 0. Poses that are not
// rigid motions, or lie beyond 1e9 m, are now exit 1 naming the file and the pose.
TEST(EvaluateCommand, FuzzFindingPosesThatAreNotRigidMotions)
{
  ScratchDir dir;
  pio::writeKittiPoses(dir / "gt.txt", circle());
  const std::string circle_text = [&] {
    std::ifstream in(dir / "gt.txt");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  const std::size_t third = [&] {
    std::size_t pos = 0;
    for (int k = 0; k < 2; ++k)
      pos = circle_text.find('\n', pos) + 1;
    return pos;
  }();
  const std::pair<const char*, const char*> bad[] = {
      {"huge.txt", "1 0 0 0 0 1 0 0 7.7e80 0 1 0\n"},
      {"scaled.txt", "2 0 0 0 0 2 0 0 0 0 2 0\n"},
      {"mirror.txt", "-1 0 0 0 0 1 0 0 0 0 1 0\n"},
      {"far.txt", "1 0 0 0 0 1 0 1e300 0 0 1 0\n"}};
  for (const auto& [name, line] : bad) {
    std::string text = circle_text;
    text.replace(third, text.find('\n', third) + 1 - third, line);
    const std::string path = dir.write(name, text);
    for (const char* align : {"none", "se3", "sim3"}) {
      const Outcome r = evaluate({path, dir / "gt.txt", "--align", align});
      EXPECT_EQ(r.code, 1) << name << ' ' << align << '\n' << r.out;
      EXPECT_HAS(r.err, std::string(name) + ": pose 3 ");
      const Outcome swapped = evaluate({dir / "gt.txt", path, "--align", align});
      EXPECT_EQ(swapped.code, 1) << name << ' ' << align << '\n' << swapped.out;
    }
  }
  EXPECT_THROW(ev::evaluateTrajectory(circle(),
                                      [] {
                                        auto p = circle();
                                        p[1](0, 0) = 7.7e80;
                                        return p;
                                      }()),
               std::invalid_argument);
}

// A statistic without a single pair is an error, not a perfect score: --delta as long as
// the trajectory left the per-frame RPE with no pair, printed as 0.0000 with exit 0.
TEST(EvaluateCommand, NoPairForTheFrameRpeExitsOne)
{
  ScratchDir dir;
  pio::writeKittiPoses(dir / "gt.txt", circle());
  const std::string gt = dir / "gt.txt";
  const std::size_t n = circle().size();
  EXPECT_EQ(evaluate({gt, gt, "--delta", std::to_string(n - 1)}).code, 0);
  const Outcome none = evaluate({gt, gt, "--delta", std::to_string(n)});
  EXPECT_EQ(none.code, 1);
  EXPECT_HAS(none.err, "has no pose pair in " + std::to_string(n) + " poses");
  EXPECT_TRUE(none.out.empty()) << none.out;
}

TEST(EvaluateCommand, BadUsageExitsTwo)
{
  ScratchDir dir;
  pio::writeKittiPoses(dir / "gt.txt", circle());
  const std::string gt = dir / "gt.txt";
  EXPECT_EQ(evaluate({gt}).code, 2);
  EXPECT_EQ(evaluate({gt, gt, "--frobnicate"}).code, 2);
  const Outcome align = evaluate({gt, gt, "--align", "sim2"});
  EXPECT_EQ(align.code, 2);
  EXPECT_HAS(align.err, "unknown alignment \"sim2\"");
  EXPECT_EQ(evaluate({gt, gt, "--lengths", "10,x"}).code, 2);
  EXPECT_EQ(evaluate({gt, gt, "--delta", "0"}).code, 2);
  for (const char* option : {"--delta", "--step"}) { // a negative count wrapped to 2^64 - 1
    const Outcome negative = evaluate({gt, gt, option, "-1"});
    EXPECT_EQ(negative.code, 2) << option;
    EXPECT_HAS(negative.err, "frame count from 1 to 1e9");
  }
  EXPECT_EQ(evaluate({gt, gt, "a-third-file"}).code, 2);
  const Outcome missing = evaluate({"/nonexistent", gt}); // as run's missing directory
  EXPECT_EQ(missing.code, 2);
  EXPECT_HAS(missing.err, "/nonexistent: no such file or directory");
  const Outcome help = evaluate({"--help"});
  EXPECT_EQ(help.code, 0);
  EXPECT_HAS(help.out, "--align");
}

// --relations: Kümmerle et al.'s metric instead of a ground truth. A heading bias of 10°
// on every pose turns each 1 m step into an error of 2 sin(5°) m (test_evaluation's
// Relations tests derive it); table, JSON, and the errors' exit codes.
TEST(EvaluateCommand, RelationsGiveThePapersTableAndExitOneWithoutAMatch)
{
  ScratchDir dir;
  constexpr double b = 10.0 * M_PI / 180.0;
  Poses biased;
  std::vector<double> stamps;
  std::string relations;
  for (int i = 0; i < 4; ++i) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = Eigen::AngleAxisd(b, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    m(0, 3) = i;
    biased.push_back(m);
    stamps.push_back(50.0 + i);
    if (i > 0)
      relations += std::to_string(49 + i) + " " + std::to_string(50 + i) + " 1 0 0 0 0 0\n";
  }
  pio::writeTumTrajectory(dir / "est.tum", biased, stamps);
  const std::string rel = dir.write("steps.relations", relations);
  const Outcome table = evaluate({dir / "est.tum", "--relations", rel});
  ASSERT_EQ(table.code, 0) << table.err;
  EXPECT_HAS(table.out, "matched       3 relations by timestamp");
  EXPECT_HAS(table.out, "translation [m]");
  const Outcome json = evaluate({dir / "est.tum", "--relations", rel, "--json"});
  ASSERT_EQ(json.code, 0) << json.err;
  const auto j = nlohmann::json::parse(json.out);
  EXPECT_EQ(j["used"], 3);
  EXPECT_NEAR(j["translation_m"]["mean"].get<double>(), 2.0 * std::sin(b / 2.0), 1e-9);
  EXPECT_NEAR(j["translation_m"]["std"].get<double>(), 0.0, 1e-9);
  EXPECT_NEAR(j["rotation_deg"]["mean"].get<double>(), 0.0, 1e-9);

  const Outcome none = evaluate(
      {dir / "est.tum", "--relations", dir.write("far.relations", "1 2 0 0 0 0 0 0\n")});
  EXPECT_EQ(none.code, 1);
  EXPECT_HAS(none.err, "no relation of");
  EXPECT_TRUE(none.out.empty()) << none.out;
  const Outcome bad = evaluate(
      {dir / "est.tum", "--relations", dir.write("bad.relations", relations + "1 2 3\n")});
  EXPECT_EQ(bad.code, 1);
  EXPECT_HAS(bad.err, "bad.relations:4:");
  pio::writeKittiPoses(dir / "est.txt", biased);
  const Outcome kitti = evaluate({dir / "est.txt", "--relations", rel});
  EXPECT_EQ(kitti.code, 1);
  EXPECT_HAS(kitti.err, "has no time stamps");
  EXPECT_EQ(evaluate({dir / "est.tum", dir / "est.tum", "--relations", rel}).code, 2);
  const Outcome missing = evaluate({dir / "est.tum", "--relations", dir / "none.relations"});
  EXPECT_EQ(missing.code, 2);
  EXPECT_HAS(missing.err, "none.relations: no such file or directory");
}

} // namespace
