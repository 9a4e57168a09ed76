/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The 2D logs' io. io/carmen.h: hand-written CARMEN logs (every message, the angle rule,
 * the range limits, the errors) and the three Radish logs of ../shared/data/radish_2d (their
 * README's counts). io/scan_directory.h: a log opened as a sequence of scans. io/g2o.h:
 * the SE(2) pose graph written and read back.
 */
#include "error_message.h"
#include "scratch_dir.h"
#include "test_data.h"

#include <pcl_parallel/io/carmen.h>
#include <pcl_parallel/io/g2o.h>
#include <pcl_parallel/io/scan_directory.h>

#include <boost/iostreams/filter/bzip2.hpp>
#include <boost/iostreams/filtering_stream.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <limits>
#include <sstream>
#include <string>

using pcl_parallel::test::messageOf;

using namespace pcl_parallel::io;

namespace {

constexpr double kDeg = M_PI / 180.0;

/** Files in a fresh temporary directory (test/common/scratch_dir.h), removed with the
 *  fixture. */
class CarmenFiles : public ::testing::Test {
protected:
  std::string
  write(const std::string& name, const std::string& content)
  {
    return scratch_.write(name, content);
  }
  /** content compressed with bzip2 (Boost.Iostreams, as the reader decompresses it). */
  std::string
  writeBzip2(const std::string& name, const std::string& content)
  {
    std::ofstream file(scratch_ / name, std::ios::binary);
    boost::iostreams::filtering_ostream out;
    out.push(boost::iostreams::bzip2_compressor());
    out.push(file);
    out << content;
    out.reset(); // flushes the compressor's end of stream
    return scratch_ / name;
  }
  pcl_parallel::test::ScratchDir scratch_;
};

/** "FLASER n r... x y theta odom_x odom_y odom_theta ipc host logger". */
std::string
flaser(const std::vector<std::string>& ranges,
       const std::string& laser_pose,
       const std::string& robot_pose,
       const std::string& stamps = "100.25 host 0.5")
{
  std::string line = "FLASER " + std::to_string(ranges.size());
  for (const auto& r : ranges)
    line += " " + r;
  return line + " " + laser_pose + " " + robot_pose + " " + stamps + "\n";
}

void
expectPoint(const pcl::PointXYZ& p, double range, double angle)
{
  EXPECT_NEAR(p.x, range * std::cos(angle), 1e-6);
  EXPECT_NEAR(p.y, range * std::sin(angle), 1e-6);
  EXPECT_EQ(p.z, 0.0f);
}

} // namespace

// CARMEN's readlog.c rule for the angle between beams, which FLASER lines do not carry.
TEST(Carmen, AngleIncrementFollowsCarmensGuess)
{
  EXPECT_DOUBLE_EQ(carmenGuessAngleIncrement(180), 1.0 * kDeg);
  EXPECT_DOUBLE_EQ(carmenGuessAngleIncrement(181), 1.0 * kDeg);
  EXPECT_DOUBLE_EQ(carmenGuessAngleIncrement(360), 0.5 * kDeg);
  EXPECT_DOUBLE_EQ(carmenGuessAngleIncrement(361), 0.5 * kDeg);
  EXPECT_DOUBLE_EQ(carmenGuessAngleIncrement(401), 0.25 * kDeg);
  EXPECT_DOUBLE_EQ(carmenGuessAngleIncrement(91), M_PI / 90.0); // 180° over 90 gaps
  EXPECT_DOUBLE_EQ(carmenGuessFov(180), 179.0 * kDeg);
  EXPECT_DOUBLE_EQ(carmenGuessFov(361), M_PI);
  EXPECT_TRUE(std::isfinite(carmenGuessAngleIncrement(1)));
}

// A 180-beam FLASER: beam i at -90° + i·1°, x forward and y left; "no return" (the
// saturation value, beyond the maximum), zero, NaN and inf readings dropped; both poses.
TEST_F(CarmenFiles, FlaserBeamsLieAtCarmensAnglesAndNoReturnsAreDropped)
{
  std::vector<std::string> ranges(180, "2.5");
  ranges[1] = "81.83"; // intel's "no return"
  ranges[2] = "80.0";  // the README's limit: 80 m or more is invalid
  ranges[3] = "0.0";
  ranges[4] = "nan";
  ranges[5] = "inf";
  ranges[90] = "1.5";
  const auto log = loadCarmenLog(
      write("f.clf",
            "# CARMEN Logfile\n" + flaser(ranges, "1 2 0.5", "1 2 0.5", "976052857.5 h 1.25")));
  ASSERT_EQ(log.scans.size(), 1u);
  const CarmenScan& s = log.scans[0];
  EXPECT_EQ(s.message, CarmenLaserMessage::FLaser);
  EXPECT_EQ(s.beams, 180u);
  EXPECT_EQ(s.line, 2u);
  EXPECT_DOUBLE_EQ(s.timestamp, 976052857.5);
  EXPECT_DOUBLE_EQ(s.logger_timestamp, 1.25);
  EXPECT_DOUBLE_EQ(s.angular_resolution, kDeg);
  ASSERT_EQ(s.cloud->size(), 175u);
  EXPECT_EQ(s.cloud->width, 175u);
  EXPECT_TRUE(s.cloud->is_dense);
  expectPoint((*s.cloud)[0], 2.5, -90.0 * kDeg);  // beam 0: to the right
  expectPoint((*s.cloud)[1], 2.5, -84.0 * kDeg);  // beam 6, after the five dropped
  expectPoint((*s.cloud)[85], 1.5, 0.0);          // beam 90: straight ahead
  expectPoint((*s.cloud)[174], 2.5, 89.0 * kDeg); // beam 179
  EXPECT_TRUE(s.laser_pose.isApprox(planarPose(1, 2, 0.5)));
  EXPECT_NEAR(s.laser_pose(1, 0), std::sin(0.5), 1e-15);
  EXPECT_EQ(s.laser_pose(2, 3), 0.0);
  EXPECT_TRUE(s.robot_pose.isApprox(planarPose(1, 2, 0.5)));
  EXPECT_TRUE(s.laser_offset.isApprox(Eigen::Matrix4d::Identity()));
}

// fr079's case: the laser 0.04 m behind the robot's centre along the heading; the offset
// is in the robot's frame, whatever the heading. PARAM sets the resolution and maximum.
TEST_F(CarmenFiles, FlaserWithOffsetAndTheLogsParams)
{
  const std::string params = "PARAM robot_frontlaser_offset -0.04 1.0 merci 1.0\n"
                             "PARAM laser_front_laser_resolution 0.5 1.0 merci 1.0\n"
                             "PARAM robot_front_laser_max 5.0 1.0 merci 1.0\n"
                             "PARAM robot_allow_rear_motion off 1.0 merci 1.0\n";
  const std::vector<std::string> ranges = {"1", "2", "5.0", "4.99"};
  const auto log = loadCarmenLog(write(
      "o.clf", params + flaser(ranges, "1 1.96 1.5707963267948966", "1 2 1.5707963267948966")));
  ASSERT_EQ(log.params.size(), 4u);
  EXPECT_EQ(log.params[0].name, "robot_frontlaser_offset");
  EXPECT_EQ(log.params[0].value, "-0.04");
  EXPECT_EQ(log.params[3].value, "off");
  ASSERT_EQ(log.scans.size(), 1u);
  const CarmenScan& s = log.scans[0];
  EXPECT_NEAR(s.laser_offset(0, 3), -0.04, 1e-12);
  EXPECT_NEAR(s.laser_offset(1, 3), 0.0, 1e-12);
  EXPECT_NEAR(s.laser_offset(0, 0), 1.0, 1e-12);
  EXPECT_DOUBLE_EQ(s.angular_resolution, 0.5 * kDeg); // PARAM, not the guess for 4 beams
  EXPECT_DOUBLE_EQ(s.max_range, 5.0);
  ASSERT_EQ(s.cloud->size(), 3u); // 5.0 is at the maximum: no return
  expectPoint((*s.cloud)[1], 2.0, -89.5 * kDeg);
  expectPoint((*s.cloud)[2], 4.99, -88.5 * kDeg);
}

// ROBOTLASER1 carries its start angle, resolution and maximum range; its remissions are
// skipped, its poses read.
TEST_F(CarmenFiles, RobotLaser1CarriesItsOwnGeometry)
{
  const std::string line = "ROBOTLASER1 0 -1.0 2.0 0.5 3.0 0.01 0 5 1 2 3 2.5 nan 2 7 8 "
                           "0.5 0.25 0.1 0.5 0.5 0.2 0.3 0.05 0.4 0.3 0 12.5 host 3.5\n";
  const auto log = loadCarmenLog(write("r.clf", line));
  ASSERT_EQ(log.scans.size(), 1u);
  const CarmenScan& s = log.scans[0];
  EXPECT_EQ(s.message, CarmenLaserMessage::RobotLaser1);
  EXPECT_EQ(s.beams, 5u);
  EXPECT_DOUBLE_EQ(s.start_angle, -1.0);
  EXPECT_DOUBLE_EQ(s.angular_resolution, 0.5);
  EXPECT_DOUBLE_EQ(s.max_range, 3.0);
  ASSERT_EQ(s.cloud->size(), 3u); // 3 is the maximum, nan no number of metres
  expectPoint((*s.cloud)[0], 1.0, -1.0);
  expectPoint((*s.cloud)[1], 2.0, -0.5);
  expectPoint((*s.cloud)[2], 2.5, 0.5);
  EXPECT_TRUE(s.laser_pose.isApprox(planarPose(0.5, 0.25, 0.1)));
  EXPECT_TRUE(s.robot_pose.isApprox(planarPose(0.5, 0.5, 0.2)));
  EXPECT_DOUBLE_EQ(s.timestamp, 12.5);
  // robot⁻¹·laser: the laser pose again when composed with the robot's.
  EXPECT_TRUE((s.robot_pose * s.laser_offset).isApprox(s.laser_pose, 1e-12));
}

// ODOM lines, comments, messages we do not read (counted), intel's PARAM without
// ipc_timestamp, every line end, and the same log through bzip2.
TEST_F(CarmenFiles, OdometryCommentsOtherMessagesLineEndsAndBzip2)
{
  for (const std::string end : {"\n", "\r\n", "\r"}) {
    SCOPED_TRACE(end == "\r" ? "CR" : end == "\n" ? "LF" : "CRLF");
    const std::string text = "# a comment" + end +
                             "PARAM robot_frontlaser_offset 0.0 nohost 0" + end + end +
                             "ODOM 1 2 0.25 0.5 -0.1 0 976052857.337 nohost 0.6" + end +
                             "RLASER 1 2.0 0 0 0 0 0 0 1 h 1" + end +
                             "TRUEPOS 0 0 0 0 0 0 1 h 1" + end + "SYNC tag 1 h 1" + end;
    for (const bool bz2 : {false, true}) {
      const auto path = bz2 ? writeBzip2("log.clf.bz2", text) : write("log.clf", text);
      const CarmenLog log = loadCarmenLog(path);
      ASSERT_EQ(log.odometry.size(), 1u);
      const CarmenOdometry& o = log.odometry[0];
      EXPECT_EQ(o.line, 4u);
      EXPECT_TRUE(o.pose.isApprox(planarPose(1, 2, 0.25)));
      EXPECT_DOUBLE_EQ(o.tv, 0.5);
      EXPECT_DOUBLE_EQ(o.rv, -0.1);
      EXPECT_DOUBLE_EQ(o.timestamp, 976052857.337);
      EXPECT_DOUBLE_EQ(o.logger_timestamp, 0.6);
      ASSERT_EQ(log.params.size(), 1u);
      EXPECT_EQ(log.params[0].value, "0.0");
      EXPECT_EQ(log.skipped.at("RLASER"), 1u);
      EXPECT_EQ(log.skipped.at("TRUEPOS"), 1u);
      EXPECT_EQ(log.skipped.at("SYNC"), 1u);
      EXPECT_TRUE(log.scans.empty());
      EXPECT_EQ(log.lines, 7u);
    }
  }
}

// Every bad input names the file and the line.
TEST_F(CarmenFiles, BadLinesThrowWithFileAndLine)
{
  const std::string good = flaser({"1", "2"}, "0 0 0", "0 0 0");
  const auto errorAt = [&](const std::string& name, const std::string& text) {
    return messageOf<std::runtime_error>([&] { loadCarmenLog(write(name, text)); });
  };
  std::string msg = errorAt("garbage.clf", good + "\xff\xfe garbage\n");
  EXPECT_NE(msg.find("garbage.clf:2: not a CARMEN message"), std::string::npos) << msg;
  msg = errorAt("short.clf", good + "FLASER 3 1 2 0 0 0 0 0 0 1 h 1\n");
  EXPECT_NE(msg.find("short.clf:2: \"FLASER\" needs 14 fields"), std::string::npos) << msg;
  msg = errorAt("count.clf", "FLASER -2 0 0 0 0 0 0 1 h 1\n");
  EXPECT_NE(msg.find("count.clf:1: num_readings (field 2) is no count"), std::string::npos)
      << msg;
  msg = errorAt("range.clf", good + flaser({"1", "2m"}, "0 0 0", "0 0 0"));
  EXPECT_NE(msg.find("range.clf:2: a range (field 4) is not a number: \"2m\""),
            std::string::npos)
      << msg;
  msg = errorAt("pose.clf", flaser({"1"}, "0 nan 0", "0 0 0"));
  EXPECT_NE(msg.find("pose.clf:1: y (field 5) is not finite"), std::string::npos) << msg;
  msg = errorAt("odom.clf", "\n\nODOM 1 2 3 0 0 0 1 h\n");
  EXPECT_NE(msg.find("odom.clf:3: \"ODOM\" needs 10 fields"), std::string::npos) << msg;
  msg = errorAt("stamp.clf", "ODOM 1 2 3 0 0 0 inf h 1\n");
  EXPECT_NE(msg.find("stamp.clf:1: ipc_timestamp (field 8) is not finite"), std::string::npos)
      << msg;
  msg = errorAt("param.clf", "PARAM laser_front_laser_resolution fine 1 h 1\n");
  EXPECT_NE(msg.find("param.clf:1: the value (field 3) is not a number"), std::string::npos)
      << msg;
  msg = errorAt("rl1.clf", "ROBOTLASER1 0 -1 2 0.5 3 0.01 0 2 1 2 5 7\n");
  EXPECT_NE(msg.find("rl1.clf:1: \"ROBOTLASER1\" needs"), std::string::npos) << msg;
  msg = errorAt("empty.clf", "# only a comment\n\n");
  EXPECT_NE(msg.find("empty.clf: holds no CARMEN message"), std::string::npos) << msg;
  msg = errorAt("long.clf", good + "FLASER " + std::string(70000, '1') + "\n");
  EXPECT_NE(msg.find("long.clf:2: line longer than 65536 bytes"), std::string::npos) << msg;
  msg = messageOf<std::runtime_error>([&] { loadCarmenLog(scratch_ / "missing.clf"); });
  EXPECT_NE(msg.find("missing.clf: cannot open"), std::string::npos) << msg;
}

// A .bz2 that is not bzip2, or is cut short, is an error naming the file, never a log
// silently shorter than the file.
TEST_F(CarmenFiles, CorruptAndTruncatedBzip2Throw)
{
  std::string text;
  for (int i = 0; i < 2000; ++i)
    text += "ODOM " + std::to_string(i) + " 0 0 0 0 0 " + std::to_string(i) + " h 0\n";
  const auto whole = writeBzip2("whole.clf.bz2", text);
  EXPECT_EQ(loadCarmenLog(whole).odometry.size(), 2000u);
  std::ifstream in(whole, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)),
                          std::istreambuf_iterator<char>());
  std::string msg = messageOf<std::runtime_error>(
      [&] { loadCarmenLog(write("cut.clf.bz2", bytes.substr(0, bytes.size() / 2))); });
  EXPECT_NE(msg.find("cut.clf.bz2:1: cannot decompress: the bzip2 stream ends early"),
            std::string::npos)
      << msg;
  msg = messageOf<std::runtime_error>([&] { loadCarmenLog(write("text.clf.bz2", text)); });
  EXPECT_NE(msg.find("text.clf.bz2:1: cannot decompress: not bzip2 data"), std::string::npos)
      << msg;
}

namespace {

/** What the radish_2d README states of one log. */
struct RadishLog {
  const char* file;
  std::size_t scans, beams, odometry, params;
  double duration_s, odometry_path_m, resolution_deg, offset_m, dropped_percent;
};

/** Path length along the poses' positions. */
template <typename Poses>
double
pathLength(const Poses& poses)
{
  double length = 0.0;
  for (std::size_t i = 1; i < poses.size(); ++i)
    length += (poses[i].col(3) - poses[i - 1].col(3)).norm();
  return length;
}

void
checkRadishLog(const RadishLog& expected)
{
  PCL_PARALLEL_REQUIRE_DATA(path, std::string("radish_2d/") + expected.file);
  const CarmenLog log = loadCarmenLog(path);
  ASSERT_EQ(log.scans.size(), expected.scans);
  EXPECT_EQ(log.odometry.size(), expected.odometry);
  EXPECT_EQ(log.params.size(), expected.params);
  std::size_t beams = 0, kept = 0;
  double first = std::numeric_limits<double>::infinity(), last = -first;
  std::vector<Eigen::Matrix4d> robot;
  for (const CarmenScan& s : log.scans) {
    EXPECT_EQ(s.beams, expected.beams);
    EXPECT_NEAR(s.angular_resolution, expected.resolution_deg * kDeg, 1e-12);
    EXPECT_NEAR(s.laser_offset(0, 3), expected.offset_m, 1e-5);
    EXPECT_NEAR(s.laser_offset(1, 3), 0.0, 1e-5);
    beams += s.beams;
    kept += s.cloud->size();
    for (const auto& p : *s.cloud) // no "no return" left: the real readings end at 42.4 m
      ASSERT_LT(std::hypot(p.x, p.y), 50.0f);
    first = std::min(first, s.timestamp);
    last = std::max(last, s.timestamp);
    robot.push_back(s.robot_pose);
  }
  for (const CarmenOdometry& o : log.odometry) {
    first = std::min(first, o.timestamp);
    last = std::max(last, o.timestamp);
  }
  // The README gives one decimal: durations to 0.1 s, paths to 0.1 m, shares to 0.05 %.
  EXPECT_NEAR(last - first, expected.duration_s, 0.1);
  // mit-csail has no ODOM: its odometry is the FLASER lines' robot poses (the README).
  std::vector<Eigen::Matrix4d> odometry;
  for (const CarmenOdometry& o : log.odometry)
    odometry.push_back(o.pose);
  EXPECT_NEAR(pathLength(odometry.empty() ? robot : odometry), expected.odometry_path_m, 0.1);
  EXPECT_NEAR(100.0 * static_cast<double>(beams - kept) / static_cast<double>(beams),
              expected.dropped_percent,
              0.05);
}

} // namespace

// The README's numbers (counted there by decompressing and parsing every line).
TEST(CarmenData, IntelAsItsReadmeStates)
{
  checkRadishLog({"intel.clf.bz2", 13631, 180, 26915, 2, 2691.3, 509.1, 1.0, 0.0, 2.8});
}

TEST(CarmenData, Fr079AsItsReadmeStates)
{
  checkRadishLog({"fr079.clf.bz2", 4934, 360, 8951, 187, 1061.7, 391.8, 0.5, -0.04, 2.1});
}

TEST(CarmenData, MitCsailAsItsReadmeStates)
{
  checkRadishLog({"mit-csail.clf.bz2", 1988, 361, 0, 0, 424.0, 373.6, 0.5, 0.0, 3.3});
}

// A log opened as a scan sequence: time order (its lines are not in every log), the scans
// numbered in it, kept where the odometry moved or turned enough since the last scan
// kept, each with the laser's odometry pose and its stamp; 2D; a log's options refused.
TEST_F(CarmenFiles, LogOpensAsTheScansTakenWhereTheRobotMovedEnough)
{
  const std::vector<std::string> r = {"1.0", "2.0", "81.83", "1.5"};
  // Poses (x, theta) in time order; the lines below put stamp 3 before stamp 2.
  const double x[] = {0.0, 0.3, 0.6, 0.6, 0.6, 1.2}, th[] = {0.0, 0.0, 0.0, 0.3, 0.6, 0.6};
  const int line_order[] = {0, 1, 3, 2, 4, 5};
  std::string text;
  for (const int i : line_order) {
    const std::string pose = std::to_string(x[i]) + " 0 " + std::to_string(th[i]);
    text += flaser(r, pose, pose, std::to_string(10.0 + i) + " host " + std::to_string(i));
  }
  text += flaser({"81.83", "81.83", "81.83", "81.83"}, "9 0 0", "9 0 0", "20 host 10");
  const std::string path = writeBzip2("log.clf.bz2", text);
  EXPECT_TRUE(isCarmenLogName(path));
  EXPECT_TRUE(isCarmenLogName("/a/B.CLF"));
  EXPECT_FALSE(isCarmenLogName("/a/log.clf.gz"));
  ScanDirectoryOptions o;
  o.dir = path;
  o.min_travel = 0.5;
  o.min_turn = 0.5;
  const ScanDirectory in = openScanDirectory(o);
  // Kept: 0 (first), 2 (0.6 m from 0), 4 (turned 0.6 rad from 2), 5 (0.6 m from 4); the
  // last line has no return.
  EXPECT_EQ(in.numbers, (std::vector<int>{0, 2, 4, 5}));
  EXPECT_EQ(in.stamps, (std::vector<double>{10, 12, 14, 15}));
  EXPECT_EQ(in.log_scans, 7u);
  EXPECT_TRUE(in.planar);
  EXPECT_TRUE(in.odometry);
  EXPECT_TRUE(in.has_stamps);
  ASSERT_EQ(in.size(), 4u);
  EXPECT_TRUE(in.initial[2].isApprox(planarPose(0.6, 0, 0.6)));
  EXPECT_EQ(in.files[1], path + ":4"); // the log's line
  const auto scan = readScan(in, 1);
  ASSERT_EQ(scan->size(), 3u); // the no-return beam dropped
  expectPoint((*scan)[0], 1.0, -90 * kDeg);
  // -s/-e count the log's scans before the selection by motion; 0 and 0 keep every scan.
  o.first = 1, o.last = 4;
  EXPECT_EQ(openScanDirectory(o).numbers, (std::vector<int>{1, 4}));
  o.min_travel = o.min_turn = 0.0;
  EXPECT_EQ(openScanDirectory(o).numbers, (std::vector<int>{1, 2, 3, 4}));
  // What a log holds itself, or too few scans, is refused naming the log.
  o.first = 0, o.last = -1;
  o.poses_file = write("poses.txt", "");
  EXPECT_THROW(openScanDirectory(o), ScanDirectoryUsageError);
  o.poses_file.clear();
  o.min_travel = o.min_turn = 100.0;
  EXPECT_NE(messageOf<ScanDirectoryUsageError>([&] { openScanDirectory(o); }).find(path),
            std::string::npos);
}

// g2o's SE(2) lines: the numbers read back exactly; an edge checked by hand.
TEST_F(CarmenFiles, G2oSe2WritesVerticesAndEdgesThatReadBack)
{
  const std::vector<Eigen::Matrix4d> poses = {
      planarPose(1, 2, M_PI / 2), planarPose(1, 3, M_PI), planarPose(-0.1, 1e-7, -3.0)};
  Eigen::Matrix3d info;
  info << 100, 1, 2, 1, 200, 3, 2, 3, 1000;
  std::vector<G2oEdgeSe2> edges = {g2oEdgeBetween(poses, 0, 1, info),
                                   g2oEdgeBetween(poses, 2, 0)};
  const std::string path = scratch_ / "graph.g2o";
  writeG2oSe2(path, poses, edges);
  std::ifstream in(path);
  std::string tag;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    std::size_t id;
    double x, y, theta;
    ASSERT_TRUE(in >> tag >> id >> x >> y >> theta);
    EXPECT_EQ(tag, "VERTEX_SE2");
    EXPECT_EQ(id, i);
    EXPECT_EQ(x, poses[i](0, 3));
    EXPECT_EQ(y, poses[i](1, 3));
    EXPECT_EQ(theta, std::atan2(poses[i](1, 0), poses[i](0, 0)));
  }
  double v[9];
  std::size_t from, to;
  ASSERT_TRUE(in >> tag >> from >> to);
  for (double& x : v)
    ASSERT_TRUE(in >> x);
  EXPECT_EQ(tag, "EDGE_SE2");
  EXPECT_EQ(from, 0u);
  EXPECT_EQ(to, 1u);
  // By hand: from (1, 2) facing +y, the pose at (1, 3) facing -x is 1 m ahead, turned +90°.
  EXPECT_NEAR(v[0], 1.0, 1e-15);
  EXPECT_NEAR(v[1], 0.0, 1e-15);
  EXPECT_NEAR(v[2], M_PI / 2, 1e-15);
  EXPECT_EQ((std::vector<double>(v + 3, v + 9)),
            (std::vector<double>{100, 1, 2, 200, 3, 1000}));
  ASSERT_TRUE(in >> tag >> from >> to);
  EXPECT_EQ(from, 2u);
  EXPECT_EQ(to, 0u);
  for (double& x : v)
    ASSERT_TRUE(in >> x);
  EXPECT_EQ(v[3], 1.0);
  EXPECT_EQ(v[4], 0.0);
  EXPECT_FALSE(in >> tag); // nothing more
}

// What no SE(2) graph holds is refused before a file is written.
TEST_F(CarmenFiles, G2oSe2RefusesWhatIsNoPlanarGraph)
{
  const std::string path = scratch_ / "bad.g2o";
  std::vector<Eigen::Matrix4d> poses = {planarPose(0, 0, 0), planarPose(1, 0, 0)};
  EXPECT_NO_THROW(writeG2oSe2(path, poses, {g2oEdgeBetween(poses, 0, 1)}));
  std::filesystem::remove(path);
  EXPECT_THROW(g2oEdgeBetween(poses, 0, 2), std::out_of_range);
  G2oEdgeSe2 beyond;
  beyond.to = 2;
  EXPECT_THROW(writeG2oSe2(path, poses, {beyond}), std::invalid_argument);
  G2oEdgeSe2 skew = g2oEdgeBetween(poses, 0, 1);
  skew.information(0, 1) = 5;
  EXPECT_THROW(writeG2oSe2(path, poses, {skew}), std::invalid_argument);
  poses[1].topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_THROW(writeG2oSe2(path, poses, {}), std::invalid_argument);
  poses[1] = planarPose(std::nan(""), 0, 0);
  EXPECT_THROW(writeG2oSe2(path, poses, {}), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(path));
}
