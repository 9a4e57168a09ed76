/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "error_message.h"
#include "test_data.h"

#include <pcl_parallel/io/atomic_write.h>
#include <pcl_parallel/io/output_directory.h>
#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/io/scan_directory.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/stanford.h>
#include <pcl_parallel/io/stderr_capture.h>
#include <pcl_parallel/io/uos.h>
#include <pcl_parallel/sim/scan_set_writer.h>

#include <pcl/io/auto_io.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <initializer_list>
#include <iostream>
#include <iterator>
#include <limits>
#include <locale>
#include <map>
#include <random>
#include <string>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <utility>
#include <vector>

using pcl_parallel::test::messageOf;

using namespace pcl_parallel::io;

namespace {

/** A file in a fresh temporary directory, removed with the fixture. */
class TempFiles : public ::testing::Test {
protected:
  void
  SetUp() override
  {
    dir_ = std::filesystem::temp_directory_path() /
           ("pcl_parallel_io_" +
            std::to_string(::testing::UnitTest::GetInstance()->random_seed()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void
  TearDown() override
  {
    std::filesystem::remove_all(dir_);
  }
  std::string
  write(const std::string& name, const std::string& content)
  {
    const auto p = dir_ / name;
    std::ofstream(p, std::ios::binary) << content;
    return p.string();
  }
  std::filesystem::path dir_;
};

bool
mentions(const std::string& message, const std::string& part)
{
  return message.find(part) != std::string::npos;
}

/** KITTI .bin bytes: the values as float32, little-endian whatever the host. */
std::string
kittiBytes(std::initializer_list<float> values)
{
  std::string bytes;
  for (float v : values) {
    std::uint32_t u;
    std::memcpy(&u, &v, sizeof u);
    for (int i = 0; i < 4; ++i)
      bytes.push_back(static_cast<char>((u >> (8 * i)) & 0xffu));
  }
  return bytes;
}

void
expectPoint(const pcl::PointXYZ& p, float x, float y, float z)
{
  EXPECT_EQ(p.x, x);
  EXPECT_EQ(p.y, y);
  EXPECT_EQ(p.z, z);
}

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

std::string
quoted(const char* s)
{
  return "\"" + std::string(s) + "\"";
}

} // namespace

// A writer that fails leaves neither the file nor a temporary; an old file stays intact.
TEST_F(TempFiles, AtomicWritesLeaveTheOldFileOrTheNewOne)
{
  namespace fs = std::filesystem;
  const fs::path dir = dir_;
  const std::string path = (dir / "poses.txt").string();
  EXPECT_THROW(writeAtomically(path,
                               [](const std::string& tmp) {
                                 std::ofstream(tmp) << "half";
                                 throw std::runtime_error("disk full");
                               }),
               std::runtime_error);
  EXPECT_TRUE(fs::is_empty(dir));
  std::ofstream(path) << "old\n";
  EXPECT_THROW(writeAtomically(path,
                               [](const std::string& tmp) {
                                 std::ofstream(tmp) << "new, half";
                                 throw std::runtime_error("interrupted");
                               }),
               std::runtime_error);
  std::ifstream in(path);
  std::string content;
  std::getline(in, content);
  EXPECT_EQ(content, "old");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  writeAtomically(path, [](const std::string& tmp) { std::ofstream(tmp) << "new\n"; });
  std::ifstream in2(path);
  std::getline(in2, content);
  EXPECT_EQ(content, "new");
  // A failure names the file asked for, not its temporary; a WriteAborted (a signal)
  // passes unchanged, and leaves no temporary either.
  const std::string failed = messageOf<std::runtime_error>([&] {
    writeAtomically(path, [](const std::string& tmp) {
      throw std::runtime_error(tmp + ": cannot write the picture");
    });
  });
  EXPECT_EQ(failed, path + ": cannot write the picture");
  const std::string aborted = messageOf<WriteAborted>([&] {
    writeAtomically(path, [](const std::string& tmp) {
      std::ofstream(tmp) << "half";
      throw WriteAborted("interrupted (SIGINT)");
    });
  });
  EXPECT_EQ(aborted, "interrupted (SIGINT)");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  EXPECT_TRUE(mentions(messageOf<std::runtime_error>([&] {
                         writeStreamAtomically((dir / "no/such/dir/p.txt").string(),
                                               [](std::ostream& out) { out << "x"; });
                       }),
                       "p.txt: cannot open for writing"));
}

/** The names in `dir`, sorted, with their bytes. */
std::map<std::string, std::string>
contentsOf(const std::filesystem::path& dir)
{
  std::map<std::string, std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    std::ifstream in(entry.path(), std::ios::binary);
    files[entry.path().filename().string()] =
        std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  return files;
}

// A run's outputs are one unit (io::OutputDirectory): the target holds the earlier run's
// files until commit() swaps the new ones in, byte for byte one run's or the other's;
// without commit() nothing of the new run stays; names no run writes make it refused.
// The names a run writes, a simulated scan set holds and an atomic write leaves behind,
// each against names one character off.
TEST(FileNames, RunOutputsScanSetsAndTemporariesByTheirShapes)
{
  namespace io = pcl_parallel::io;
  namespace sim = pcl_parallel::sim;
  for (const char* name : {"scan000.frames",
                           "scan1234.frames",
                           "poses.txt",
                           "poses_icp.txt",
                           "poses_tum.txt",
                           "poses_icp_tum.txt",
                           "map.pcd",
                           "map.ply",
                           "map_rank1.pcd",
                           "map_rank12.ply",
                           "map.png",
                           "report.json"})
    EXPECT_TRUE(io::isRunOutputName(name)) << name;
  for (const char* name : {"scan.frames",
                           "scanx.frames",
                           "scan1.frame",
                           "poses_tum_icp.txt",
                           "map_rank.pcd",
                           "map_rank1.png",
                           "map.jpg",
                           "report.json~",
                           ""})
    EXPECT_FALSE(io::isRunOutputName(name)) << name;
  for (const char* name : {"scan000.3d",
                           "scan042.pose",
                           "000042.bin",
                           "123456.pcd",
                           "odometry.txt",
                           "times.txt",
                           "ground_truth.txt"})
    EXPECT_TRUE(sim::isScanSetName(name)) << name;
  for (const char* name : {"scan0000.3d",
                           "scan42.pose",
                           "00042.bin",
                           "1234567.pcd",
                           "000042.ply",
                           "poses.txt",
                           "scan000.3d.bak"})
    EXPECT_FALSE(sim::isScanSetName(name)) << name;
  for (const char* name : {".map.pcd.tmp1", ".a.tmp1.tmp23", ".x.tmp0"})
    EXPECT_TRUE(io::isAtomicWriteTemporary(name)) << name;
  for (const char* name : {"map.pcd.tmp1", "..tmp1", ".map.pcd.tmp", ".map.pcd.tmp1x", ".tmp1"})
    EXPECT_FALSE(io::isAtomicWriteTemporary(name)) << name;
}

TEST_F(TempFiles, OutputDirectoryHoldsOneRunsOutputs)
{
  namespace io = pcl_parallel::io;
  const std::filesystem::path target = dir_ / "runs" / "out";
  const auto writeRun = [](const std::string& dir, const std::string& text, int scans) {
    for (int k = 0; k < scans; ++k)
      std::ofstream(dir + "/scan00" + std::to_string(k) + ".frames") << text << k;
    std::ofstream(dir + "/poses.txt") << text;
  };
  {
    io::OutputDirectory first(target.string(), io::isRunOutputName); // parents created
    EXPECT_FALSE(std::filesystem::exists(target));
    writeRun(first.path(), "first", 4);
    EXPECT_FALSE(first.replacesEarlierRun());
    first.commit();
  }
  const auto earlier = contentsOf(target);
  ASSERT_EQ(earlier.size(), 5u);
  {
    io::OutputDirectory aborted(target.string(), io::isRunOutputName);
    EXPECT_TRUE(aborted.replacesEarlierRun());
    writeRun(aborted.path(), "aborted", 2);
    EXPECT_EQ(aborted.inTarget("cannot write " + aborted.path() + "/poses.txt"),
              "cannot write " + target.string() + "/poses.txt");
  } // no commit: an error or a signal ended the run
  EXPECT_EQ(contentsOf(target), earlier);
  {
    io::OutputDirectory second(target.string(), io::isRunOutputName);
    writeRun(second.path(), "second", 2);
    second.commit();
  }
  const auto now = contentsOf(target);
  EXPECT_EQ(now.size(), 3u); // scan002.frames and scan003.frames of the first run gone
  EXPECT_EQ(now.at("poses.txt"), "second");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(target.parent_path()),
                          std::filesystem::directory_iterator()),
            1); // no temporary beside

  std::ofstream(target / "notes.md") << "mine";
  EXPECT_TRUE(mentions(messageOf<io::OutputDirectoryError>(
                           [&] { io::OutputDirectory(target.string(), io::isRunOutputName); }),
                       "holds what no run wrote (notes.md)"));
  EXPECT_TRUE(mentions(messageOf<io::OutputDirectoryError>([&] {
                         io::OutputDirectory((target / "notes.md").string(),
                                             io::isRunOutputName);
                       }),
                       "notes.md: exists and is not a directory"));
  EXPECT_EQ(contentsOf(target).at("notes.md"), "mine");
}

// What a killed run leaves beside the target (its temporary directory, named by host and
// pid) is removed by the next run there; a live process's is kept.
TEST_F(TempFiles, OutputDirectoryRemovesTheTemporariesOfKilledRuns)
{
  namespace io = pcl_parallel::io;
  const pid_t child = ::fork(); // a pid that has ended
  if (child == 0)
    ::_exit(0);
  ASSERT_GT(child, 0);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  const std::string prefix = ".out.pcl_pslam-";
  const std::string own = io::temporaryName(prefix); // this process: alive
  std::string killed = own.substr(0, own.rfind('-') + 1) + std::to_string(child) + ".0";
  for (const std::string& name : {own + ".7", killed}) {
    std::filesystem::create_directories(dir_ / name);
    std::ofstream(dir_ / name / "map.pcd") << "partial";
  }
  {
    io::OutputDirectory next((dir_ / "out").string(), io::isRunOutputName);
  }
  EXPECT_FALSE(std::filesystem::exists(dir_ / killed));
  EXPECT_TRUE(std::filesystem::exists(dir_ / (own + ".7")));
  EXPECT_EQ(io::removeStaleTemporaries(dir_.string(), prefix), 0u);
}

// A temporary directory (the demo's scans) goes with its owner, and with a signal before
// (removeTemporariesNow, as the handler calls it), files and all.
TEST(TemporaryDirectory, GoesWithItsOwnerOrASignal)
{
  namespace io = pcl_parallel::io;
  std::string kept;
  {
    io::TemporaryDirectory dir("pcl_parallel_test_tmp-");
    kept = dir.path();
    ASSERT_TRUE(std::filesystem::is_directory(kept));
    std::ofstream(kept + "/scan000.3d") << "0 0 1\n";
    io::TemporaryDirectory other("pcl_parallel_test_tmp-");
    EXPECT_NE(other.path(), kept);
    io::removeTemporariesNow();
    EXPECT_FALSE(std::filesystem::exists(kept));
    EXPECT_FALSE(std::filesystem::exists(other.path()));
    std::filesystem::create_directories(kept);
  }
  EXPECT_FALSE(std::filesystem::exists(kept));
}

// The maps are written by io/, not by PCL's writers (which fail silently or by SIGBUS on
// a full disk): the PCD is byte for byte PCL's binary PCD, the PLY reads back in PCL.
TEST_F(TempFiles, PcdAndPlyWritersAsPclWritesAndReadsThem)
{
  const std::filesystem::path dir = dir_;
  pcl::PointCloud<pcl::PointXYZ> map;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-50.0f, 50.0f);
  for (int i = 0; i < 70000; ++i) // more than one write chunk (65536 points)
    map.emplace_back(u(rng), u(rng), u(rng));
  const std::string ours = (dir / "map.pcd").string(), pcl = (dir / "pcl.pcd").string();
  writePcdScan(ours, map);
  ASSERT_EQ(pcl::io::savePCDFileBinary(pcl, map), 0);
  auto bytes = [](const std::string& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  EXPECT_TRUE(bytes(ours) == bytes(pcl));
  const std::string ply = (dir / "map.ply").string();
  writePlyScan(ply, map);
  pcl::PointCloud<pcl::PointXYZ> back;
  ASSERT_EQ(pcl::io::loadPLYFile(ply, back), 0);
  ASSERT_EQ(back.size(), map.size());
  for (std::size_t i = 0; i < map.size(); ++i)
    ASSERT_TRUE(back[i].getVector3fMap() == map[i].getVector3fMap()) << i;
  // An empty map is a valid file: the header alone, no points (not read back by PCL,
  // whose reader binds a reference to the empty data, which UBSan reports).
  writePcdScan(ours, pcl::PointCloud<pcl::PointXYZ>());
  const std::string empty = bytes(ours);
  EXPECT_NE(empty.find("\nPOINTS 0\n"), std::string::npos) << empty;
  EXPECT_EQ(empty.substr(empty.size() - std::string("DATA binary\n").size()), "DATA binary\n");
  EXPECT_EQ(loadPlyScan(ply)->size(), map.size()); // and by ours
}

// The scan directory: numbered names in their numbers' order, first/last in those numbers,
// the caller's mistakes and bad data as two error types (the app's exit 2 and 1).
TEST_F(TempFiles, ScanDirectoryNumbersSelectsAndTypesItsErrors)
{
  for (const char* name : {"scan10.xyz", "scan2.xyz", "scan7.xyz"})
    write(name, "1 0 0\n0 1 0\n0 0 1\n2 2 2\n");
  ScanDirectoryOptions o;
  o.dir = dir_.string();
  const ScanDirectory all = openScanDirectory(o);
  EXPECT_EQ(all.numbers, (std::vector<int>{2, 7, 10}));
  EXPECT_EQ(all.stamps, (std::vector<double>{2, 7, 10})); // the numbers, without times
  EXPECT_FALSE(all.odometry);
  EXPECT_EQ(all.format, "xyz");
  EXPECT_EQ(readAllScans(all).size(), 3u);
  o.first = 7;
  EXPECT_EQ(openScanDirectory(o).numbers, (std::vector<int>{7, 10}));
  o.first = 10;
  EXPECT_TRUE(mentions(messageOf<ScanDirectoryUsageError>([&] { openScanDirectory(o); }),
                       "1 of its 3 .xyz scans lie in the range -s 10"));
  o.first = 0;
  o.format = "pcd";
  EXPECT_TRUE(mentions(messageOf<ScanDataError>([&] { openScanDirectory(o); }),
                       "no scan files (.pcd)"));
  o.dir = (dir_ / "missing").string();
  EXPECT_TRUE(mentions(messageOf<ScanDirectoryUsageError>([&] { openScanDirectory(o); }),
                       "missing: no such directory"));
}

// Every initial pose is checked where it is read, naming its file: not finite, not a
// rigid motion (a mirrored, scaled or sheared rotation), or beyond 1e9 m (after the
// format's unit: a 3DTK .pose is in centimetres). A good pose file passes unchanged.
TEST_F(TempFiles, ScanDirectoryRefusesPosesThatAreNoPoses)
{
  for (const char* name : {"scan0.xyz", "scan1.xyz"})
    write(name, "1 0 0\n0 1 0\n0 0 1\n2 2 2\n");
  ScanDirectoryOptions o;
  o.dir = dir_.string();
  const std::string identity = "1 0 0 0 0 1 0 0 0 0 1 0\n";
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"-1 0 0 0 0 1 0 0 0 0 1 0\n", "pose 2 is not a rigid motion"},  // mirrored
      {"2 0 0 0 0 2 0 0 0 0 2 0\n", "pose 2 is not a rigid motion"},   // scaled
      {"1 0.5 0 0 0 1 0 0 0 0 1 0\n", "pose 2 is not a rigid motion"}, // sheared
      {"1 0 0 1e10 0 1 0 0 0 0 1 0\n", "pose 2 lies beyond 1e9 m"}};
  for (const auto& [line, problem] : bad) {
    o.poses_file = write("poses.txt", identity + line);
    const std::string msg = messageOf<ScanDataError>([&] { openScanDirectory(o); });
    EXPECT_TRUE(mentions(msg, "poses.txt: " + problem)) << msg;
  }
  o.poses_file = write("poses.txt", identity + "0 -1 0 5 1 0 0 6 0 0 1 7\n");
  const ScanDirectory good = openScanDirectory(o);
  ASSERT_TRUE(good.odometry);
  EXPECT_EQ(good.initial[1](0, 3), 5.0);

  std::filesystem::remove_all(dir_);
  std::filesystem::create_directories(dir_);
  for (const char* name : {"scan000.3d", "scan001.3d"})
    write(name, "3 x 1\n100 0 0\n0 100 0\n0 0 100\n");
  write("scan000.pose", "0 0 0\n0 0 0\n");
  write("scan001.pose", "1e300 0 0\n0 0 0\n");
  ScanDirectoryOptions u;
  u.dir = dir_.string();
  const std::string msg = messageOf<ScanDataError>([&] { openScanDirectory(u); });
  EXPECT_TRUE(mentions(msg, "scan001.pose: the pose lies beyond 1e9 m")) << msg;
  write("scan001.pose", "1e10 0 0\n0 0 0\n"); // 1e8 m
  EXPECT_EQ(openScanDirectory(u).initial[1](0, 3), 1e8);
}

// What comes with the scans must fit them, wherever it comes from: a times.txt found
// beside them with another count is an error as the same file given as times_file is; a
// missing .pose is an error where other scans have theirs (the first one too); so is an
// empty scan file, before any scan is read; a directory that is a link loop is a usage
// error naming it, not a raw filesystem exception.
TEST_F(TempFiles, ScanDirectoryRefusesTimesAndPosesThatDoNotFit)
{
  for (const char* name : {"scan000.3d", "scan001.3d", "scan002.3d"})
    write(name, "3 x 1\n100 0 0\n0 100 0\n0 0 100\n");
  ScanDirectoryOptions o;
  o.dir = dir_.string();
  EXPECT_FALSE(openScanDirectory(o).odometry);
  write("scan001.pose", "0 0 0\n0 0 0\n");
  write("scan002.pose", "0 0 0\n0 0 0\n");
  std::string msg = messageOf<ScanDataError>([&] { openScanDirectory(o); });
  EXPECT_TRUE(mentions(msg, "scan000.pose: missing (other scans have .pose files)")) << msg;
  o.no_poses = true;
  EXPECT_FALSE(openScanDirectory(o).odometry);

  write("times.txt", "0.1\n0.2\n");
  msg = messageOf<ScanDataError>([&] { openScanDirectory(o); });
  EXPECT_TRUE(mentions(msg, "times.txt: 2 timestamps for 3 scans")) << msg;
  write("times.txt", "0.1\n0.2\n0.3\n");
  EXPECT_EQ(openScanDirectory(o).stamps, (std::vector<double>{0.1, 0.2, 0.3}));

  write("scan001.3d", ""); // an empty scan: refused before the first is read
  msg = messageOf<ScanDataError>([&] { openScanDirectory(o); });
  EXPECT_TRUE(mentions(msg, "scan001.3d: empty file")) << msg;

  const std::filesystem::path loop = dir_ / "loop";
  std::filesystem::create_symlink(loop, loop);
  o.dir = loop.string();
  msg = messageOf<ScanDirectoryUsageError>([&] { openScanDirectory(o); });
  EXPECT_TRUE(mentions(msg, "loop: ")) << msg;
}

// odometry.txt in the directory (as `pcl_pslam simulate` writes it) is its odometry unless
// a poses file is named or no_poses; it goes before the .pose files beside .3d scans.
TEST_F(TempFiles, ScanDirectoryTakesOdometryTxtBesideTheScans)
{
  for (const char* name : {"scan000.3d", "scan001.3d"})
    write(name, "3 x 1\n100 0 0\n0 100 0\n0 0 100\n");
  write("scan000.pose", "0 0 0\n0 0 0\n");
  write("scan001.pose", "500 0 0\n0 0 0\n");
  ScanDirectoryOptions o;
  o.dir = dir_.string();
  EXPECT_DOUBLE_EQ(openScanDirectory(o).initial[1](0, 3), 5.0); // .pose, cm
  EXPECT_EQ(openScanDirectory(o).poses_file, "");
  const auto odometry =
      write("odometry.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 300 0 1 0 0 0 0 1 0\n");
  const ScanDirectory in = openScanDirectory(o);
  EXPECT_EQ(in.poses_file, odometry);
  EXPECT_DOUBLE_EQ(in.initial[1](0, 3), 3.0);
  const auto other = write("other.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 700 0 1 0 0 0 0 1 0\n");
  o.poses_file = other;
  EXPECT_DOUBLE_EQ(openScanDirectory(o).initial[1](0, 3), 7.0);
  o.poses_file.clear();
  o.no_poses = true;
  EXPECT_FALSE(openScanDirectory(o).odometry);
}

TEST_F(TempFiles, UosScanSkipsHeaderAndFiltersRange)
{
  const auto path = write("s.3d", "360 x 225\n1 0 0\n\n0 20 0 7\n3276.7 0 0\n0 0 0.05\n");
  const auto all = loadUosScan(path);
  ASSERT_EQ(all->size(), 4u);
  EXPECT_FLOAT_EQ((*all)[1].y, 20.0f);
  const auto filtered = loadUosScan(path, 0.5, 3000.0);
  ASSERT_EQ(filtered->size(), 2u);
  EXPECT_EQ(filtered->width, 2u);
}

TEST_F(TempFiles, MalformedAndTruncatedFilesThrowWithTheLine)
{
  const auto bad = write("bad.3d", "1 2 3\n4 5\n");
  try {
    loadUosScan(bad);
    FAIL() << "no exception";
  }
  catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.3d:2"), std::string::npos) << e.what();
  }
  EXPECT_EQ(loadUosScan(write("nan.3d", "1 2 3\nnan 1 1\n1 inf 1\n"))->size(), 1u); // dropped
  EXPECT_THROW(loadUosPose(write("short.pose", "1 2 3\n4 5\n")), std::runtime_error);
  EXPECT_THROW(loadFramesFinalPose(write("short.frames", "1 0 0 0 0 1 0 0\n")),
               std::runtime_error);
  EXPECT_THROW(loadUosScan((dir_ / "missing.3d").string()), std::runtime_error);
  EXPECT_THROW(loadUosPose(dir_.string()), std::runtime_error); // a directory
}

TEST_F(TempFiles, PoseFollows3dtkEulerConvention)
{
  const auto p = loadUosPose(write("p.pose", "1 2 3\n90 0 0\n"));
  // R = Rx(90°): y -> z
  const Eigen::Vector3d y = p.topLeftCorner<3, 3>() * Eigen::Vector3d::UnitY();
  EXPECT_NEAR(y.z(), 1.0, 1e-12);
  EXPECT_EQ((p.topRightCorner<3, 1>()), Eigen::Vector3d(1, 2, 3));
  const Eigen::Matrix3d r = eulerToRotation3dtk(0.1, 0.2, 0.3);
  const Eigen::Matrix3d expected = (Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()) *
                                    Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()))
                                       .toRotationMatrix();
  EXPECT_TRUE(r.isApprox(expected, 1e-14));
}

TEST(UosData, OdometryReproducesTheInitialFrameOf3dtk)
{
  PCL_PARALLEL_REQUIRE_DATA(pose, "3dtk_dat/scan002.pose");
  PCL_PARALLEL_REQUIRE_DATA(frames, "3dtk_dat/reference_frames_2009/scan002.frames");
  PCL_PARALLEL_REQUIRE_DATA(scan, "3dtk_dat/scan002.3d");
  // The first .frames line is slam6D's initial (odometry) pose, column-major.
  std::ifstream in(frames);
  Eigen::Matrix4d first;
  for (int i = 0; i < 16; ++i)
    in >> first(i % 4, i / 4);
  EXPECT_TRUE(loadUosPose(pose).isApprox(first, 1e-5)) << loadUosPose(pose) << "\n" << first;
  EXPECT_NEAR(loadFramesFinalPose(frames)(2, 3), 337.79, 0.01); // PROVENANCE.txt
  EXPECT_EQ(loadUosScan(scan)->size(), 81360u);
}

TEST_F(TempFiles, XyzScanSkipsCommentsAndBlankLinesAndReadsAnySeparator)
{
  const auto path = write("s.xyz",
                          "# x y z intensity\n"
                          "\n"
                          "1 2 3 0.5\n"
                          "  \t\r\n"
                          "4\t5\t6\n"
                          "   # indented comment\n"
                          "7,8,9,255,0,0\n"
                          "-1.5 , +2.5,3e1 label\r\n"
                          "nan nan nan 0\n"
                          "1 inf 0\n");
  const auto cloud = loadXyzScan(path);
  ASSERT_EQ(cloud->size(), 4u); // the non-finite points are dropped
  EXPECT_EQ(cloud->width, 4u);
  EXPECT_EQ(cloud->height, 1u);
  EXPECT_TRUE(cloud->is_dense);
  expectPoint((*cloud)[0], 1, 2, 3);
  expectPoint((*cloud)[1], 4, 5, 6);
  expectPoint((*cloud)[2], 7, 8, 9);
  expectPoint((*cloud)[3], -1.5f, 2.5f, 30);
}

TEST_F(TempFiles, XyzScanRangeFilterKeepsTheClosedInterval)
{
  const auto path = write("s.txt", "0 0 0.05\n1 0 0\n3 4 0\n0 0 3276.7\n");
  EXPECT_EQ(loadXyzScan(path)->size(), 4u);
  const auto filtered = loadXyzScan(path, 1.0, 5.0); // ranges 1 and 5 are inside
  ASSERT_EQ(filtered->size(), 2u);
  EXPECT_EQ(filtered->width, 2u);
  expectPoint((*filtered)[0], 1, 0, 0);
  expectPoint((*filtered)[1], 3, 4, 0);
  ASSERT_EQ(loadXyzScan(path, 1.5, 4.9)->size(), 0u);
}

TEST_F(TempFiles, XyzScanMalformedLineThrowsWithTheLine)
{
  const auto short_line = write("short.xyz", "1 2 3\n# comment\n\n4 5\n");
  EXPECT_TRUE(mentions(messageOf<std::runtime_error>([&] { loadXyzScan(short_line); }),
                       "short.xyz:4:"));
  const auto word = write("word.xyz", "1 2 3\n4 5 six 7\n");
  const std::string msg = messageOf<std::runtime_error>([&] { loadXyzScan(word); });
  EXPECT_TRUE(mentions(msg, "word.xyz:2:")) << msg;
  EXPECT_TRUE(mentions(msg, "\"six\"")) << msg;
  const auto empty_field = write("empty.xyz", "1,,2,3\n");
  EXPECT_TRUE(mentions(messageOf<std::runtime_error>([&] { loadXyzScan(empty_field); }),
                       "empty.xyz:1:"));
  EXPECT_THROW(loadXyzScan(write("leading_comma.xyz", ",1,2,3\n")), std::runtime_error);
  const auto suffix = write("suffix.xyz", "1 2 3m\n");
  EXPECT_THROW(loadXyzScan(suffix), std::runtime_error);
  const auto overflow = write("overflow.xyz", "1 2 1e999\n");
  EXPECT_THROW(loadXyzScan(overflow), std::runtime_error);
}

// Every line end convention ends a line: "\n", "\r\n" and "\r" alone (classic Mac), so a
// CR-only file is not read as one point, and an error names the line counted so. A line
// longer than 64 KiB (a file without line ends: binary data, NUL bytes) is refused naming
// the file and line, before the rest of the file is read.
TEST_F(TempFiles, TextReadersTakeEveryLineEndAndRefuseEndlessLines)
{
  for (const std::string end : {"\n", "\r\n", "\r"}) {
    SCOPED_TRACE(end == "\r" ? "CR" : end == "\n" ? "LF" : "CRLF");
    const auto cloud =
        loadXyzScan(write("ends.xyz", "1 2 3" + end + "4 5 6" + end + end + "7 8 9"));
    ASSERT_EQ(cloud->size(), 3u);
    expectPoint((*cloud)[2], 7, 8, 9);
    const auto bad = write("bad.xyz", "1 2 3" + end + end + "4 5" + end);
    EXPECT_TRUE(
        mentions(messageOf<std::runtime_error>([&] { loadXyzScan(bad); }), "bad.xyz:3:"));
    const auto uos = loadUosScan(write("s.3d", "2 x 1" + end + "1 2 3" + end + "4 5 6" + end));
    EXPECT_EQ(uos->size(), 2u);
    const auto poses = loadKittiPoses(
        write("poses.txt", "1 0 0 1 0 1 0 2 0 0 1 3" + end + "1 0 0 4 0 1 0 5 0 0 1 6" + end));
    ASSERT_EQ(poses.size(), 2u);
    EXPECT_EQ(poses[1](2, 3), 6.0);
    const auto pcd = loadPcdScan(
        write("s.pcd",
              "VERSION .7" + end + "FIELDS x y z" + end + "SIZE 4 4 4" + end + "TYPE F F F" +
                  end + "COUNT 1 1 1" + end + "WIDTH 2" + end + "HEIGHT 1" + end + "POINTS 2" +
                  end + "DATA ascii" + end + "1 2 3" + end + "4 5 6" + end));
    ASSERT_EQ(pcd->size(), 2u);
    expectPoint((*pcd)[1], 4, 5, 6);
  }
  // A "\r\n" split between two of forEachLine's 64 KiB blocks is one line end.
  const std::string split = "#" + std::string(65534, 'x') + "\r\n1 2 3\r\nfoo\r\n";
  std::string msg =
      messageOf<std::runtime_error>([&] { loadXyzScan(write("split.xyz", split)); });
  EXPECT_TRUE(mentions(msg, "split.xyz:3:")) << msg;
  const auto nul = write("nul.3d", std::string(1 << 20, '\0'));
  msg = messageOf<std::runtime_error>([&] { loadUosScan(nul); });
  EXPECT_TRUE(mentions(msg, "nul.3d:1: line longer than 65536 bytes")) << msg;
  const auto wide = write("wide.xyz", "1 2 3\n" + std::string(70000, ' ') + "4 5 6\n");
  msg = messageOf<std::runtime_error>([&] { loadXyzScan(wide); });
  EXPECT_TRUE(mentions(msg, "wide.xyz:2: line longer")) << msg;
  const auto pcd_header = write("h.pcd", "VERSION .7\n# " + std::string(70000, 'x'));
  msg = messageOf<std::runtime_error>([&] { loadPcdScan(pcd_header); });
  EXPECT_TRUE(mentions(msg, "h.pcd:2: line longer")) << msg;
}

TEST_F(TempFiles, XyzScanUnreadablePathThrows)
{
  const std::string missing = (dir_ / "missing.xyz").string();
  EXPECT_TRUE(mentions(messageOf<std::runtime_error>([&] { loadXyzScan(missing); }), missing));
  EXPECT_THROW(loadXyzScan(dir_.string()), std::runtime_error); // a directory
}

TEST_F(TempFiles, KittiScanReadsFloat32Records)
{
  const auto path = write("000000.bin",
                          kittiBytes({1.25f,
                                      -2.5f,
                                      0.125f,
                                      0.75f, // range 2.80
                                      10.0f,
                                      0.0f,
                                      -0.5f,
                                      0.25f, // range 10.01
                                      kNaN,
                                      1.0f,
                                      1.0f,
                                      0.5f, // dropped
                                      0.01f,
                                      0.02f,
                                      0.03f,
                                      1.0f})); // range 0.037
  const auto all = loadKittiScan(path);
  ASSERT_EQ(all->size(), 3u);
  EXPECT_EQ(all->width, 3u);
  expectPoint((*all)[0], 1.25f, -2.5f, 0.125f);
  expectPoint((*all)[1], 10.0f, 0.0f, -0.5f);
  expectPoint((*all)[2], 0.01f, 0.02f, 0.03f);
  const auto near = loadKittiScan(path, 0.5, 5.0);
  ASSERT_EQ(near->size(), 1u);
  expectPoint((*near)[0], 1.25f, -2.5f, 0.125f);
}

TEST_F(TempFiles, KittiScanTruncatedThrowsAndEmptyIsEmpty)
{
  std::string bytes = kittiBytes({1, 2, 3, 4, 5, 6, 7, 8});
  bytes.pop_back(); // 31 bytes
  const auto truncated = write("truncated.bin", bytes);
  const std::string msg = messageOf<std::runtime_error>([&] { loadKittiScan(truncated); });
  EXPECT_TRUE(mentions(msg, "truncated.bin")) << msg;
  EXPECT_TRUE(mentions(msg, "31")) << msg;
  const auto empty = loadKittiScan(write("empty.bin", ""));
  EXPECT_TRUE(empty->empty());
  EXPECT_EQ(empty->width, 0u);
  EXPECT_THROW(loadKittiScan((dir_ / "missing.bin").string()), std::runtime_error);
  EXPECT_THROW(loadKittiScan(dir_.string()), std::runtime_error); // a directory
}

TEST_F(TempFiles, KittiPosesAreRowMajor3x4)
{
  const auto path = write("00.txt",
                          "1 0 0 1.5 0 1 0 -2 0 0 1 3\n"
                          "\n"
                          "0 -1 0 10 1 0 0 20 0 0 1 3.000000e+01\n");
  const auto poses = loadKittiPoses(path);
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ((poses[0].topRightCorner<3, 1>()), Eigen::Vector3d(1.5, -2, 3));
  EXPECT_TRUE((poses[0].topLeftCorner<3, 3>().isIdentity(0)));
  EXPECT_EQ(poses[1](0, 1), -1.0);
  EXPECT_EQ(poses[1](1, 0), 1.0);
  EXPECT_EQ((poses[1].topRightCorner<3, 1>()), Eigen::Vector3d(10, 20, 30));
  EXPECT_EQ((poses[1].bottomRows<1>()), Eigen::RowVector4d(0, 0, 0, 1));
}

TEST_F(TempFiles, KittiPosesMalformedLineThrowsWithTheLine)
{
  const auto eleven = write("eleven.txt", "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n");
  EXPECT_TRUE(mentions(messageOf<std::runtime_error>([&] { loadKittiPoses(eleven); }),
                       "eleven.txt:2:"));
  EXPECT_THROW(loadKittiPoses(write("thirteen.txt", "1 0 0 0 0 1 0 0 0 0 1 0 7\n")),
               std::runtime_error);
  EXPECT_THROW(loadKittiPoses(write("nan.txt", "1 0 0 nan 0 1 0 0 0 0 1 0\n")),
               std::runtime_error);
  EXPECT_THROW(loadKittiPoses((dir_ / "missing.txt").string()), std::runtime_error);
}

TEST_F(TempFiles, LoadScanDispatchesOnTheExtension)
{
  const auto xyz = loadScan(write("a.xyz", "1 2 3\n0 0 100\n"), 0.0, 10.0);
  ASSERT_EQ(xyz->size(), 1u);
  expectPoint((*xyz)[0], 1, 2, 3);

  const auto bin = loadScan(write("b.bin", kittiBytes({4, 5, 6, 0.5f})));
  ASSERT_EQ(bin->size(), 1u);
  expectPoint((*bin)[0], 4, 5, 6);

  const auto txt = loadScan(write("t.txt", "# x,y,z\n1.5,2,3\n"));
  ASSERT_EQ(txt->size(), 1u);
  expectPoint((*txt)[0], 1.5f, 2, 3);

  const auto uos = loadScan(write("c.3d", "360 x 225\n7 8 9\n"));
  EXPECT_EQ(loadScan(write("c2.3d", "360x225\n7 8 9\n"))->size(), 1u);
  ASSERT_EQ(uos->size(), 1u);
  expectPoint((*uos)[0], 7, 8, 9);

  pcl::PointCloud<pcl::PointXYZ> cloud;
  cloud.push_back(pcl::PointXYZ(0.5f, -1.25f, 2.0f));
  cloud.push_back(pcl::PointXYZ(kNaN, kNaN, kNaN));
  cloud.push_back(pcl::PointXYZ(30.0f, 40.0f, 0.0f));
  cloud.is_dense = false;
  const std::string pcd = (dir_ / "d.pcd").string();
  ASSERT_EQ(pcl::io::savePCDFileBinary(pcd, cloud), 0);
  const auto from_pcd = loadScan(pcd);
  ASSERT_EQ(from_pcd->size(), 2u); // the NaN point is dropped
  EXPECT_EQ(from_pcd->width, 2u);
  EXPECT_TRUE(from_pcd->is_dense);
  expectPoint((*from_pcd)[0], 0.5f, -1.25f, 2.0f);
  expectPoint((*from_pcd)[1], 30.0f, 40.0f, 0.0f);
  ASSERT_EQ(loadScan(pcd, 0.0, 49.0)->size(), 1u); // the range filter applies

  const std::string ply = (dir_ / "e.ply").string();
  ASSERT_EQ(pcl::io::savePLYFileBinary(ply, cloud), 0);
  const auto from_ply = loadScan(ply);
  ASSERT_EQ(from_ply->size(), 2u);
  expectPoint((*from_ply)[0], 0.5f, -1.25f, 2.0f);
  expectPoint((*from_ply)[1], 30.0f, 40.0f, 0.0f);
  ASSERT_EQ(loadScan(ply, 3.0)->size(), 1u);

  const std::string upper = (dir_ / "F.PCD").string();
  std::filesystem::copy_file(pcd, upper);
  EXPECT_EQ(loadScan(upper)->size(), 2u);
  EXPECT_EQ(loadScan(write("g.Xyz", "1 1 1\n"))->size(), 1u);
}

TEST_F(TempFiles, LoadScanErrors)
{
  const auto las = write("h.las", "1 2 3\n");
  const std::string msg = messageOf<std::invalid_argument>([&] { loadScan(las); });
  for (const char* ext : {".3d", ".xyz", ".txt", ".bin", ".pcd", ".ply"})
    EXPECT_TRUE(mentions(msg, ext)) << msg;
  EXPECT_THROW(loadScan(write("noext", "1 2 3\n")), std::invalid_argument);

  const std::string missing = (dir_ / "missing.pcd").string();
  const std::string missing_msg = messageOf<std::runtime_error>([&] { loadScan(missing); });
  EXPECT_TRUE(mentions(missing_msg, missing)) << missing_msg;
  EXPECT_TRUE(mentions(missing_msg, "no such file")) << missing_msg; // ours, not PCL's
  std::filesystem::create_directories(dir_ / "dir.ply");
  EXPECT_THROW(loadScan((dir_ / "dir.ply").string()), std::runtime_error);

  const auto corrupt_pcd =
      write("corrupt.pcd", "this is not a point cloud\n\x01\x02 garbage\n");
  EXPECT_TRUE(
      mentions(messageOf<std::runtime_error>([&] { loadScan(corrupt_pcd); }), corrupt_pcd));
  EXPECT_THROW(loadScan(write("corrupt.ply", "ply\nformat nonsense\n")), std::runtime_error);
  EXPECT_THROW(loadScan(write("empty.pcd", "")), std::runtime_error);
  EXPECT_THROW(loadScan(write("short.pcd",
                              "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\n"
                              "HEIGHT 1\nPOINTS 3\nDATA binary\nabcdef")),
               std::runtime_error); // body shorter than the header says
  EXPECT_THROW(loadScan(write("no_vertex.ply", "ply\nformat ascii 1.0\nend_header\n")),
               std::runtime_error);
}

/** PCL's reading of a PCD or PLY file (pcl::io::load picks the reader by the extension;
 *  x, y, z of the finite points), to compare ours against. */
std::vector<Eigen::Vector3f>
pclPoints(const std::string& path)
{
  pcl::PointCloud<pcl::PointXYZ> cloud;
  EXPECT_EQ(pcl::io::load(path, cloud), 0) << path;
  std::vector<Eigen::Vector3f> points;
  for (const auto& p : cloud)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
      points.push_back(p.getVector3fMap());
  return points;
}

void
expectSamePoints(const pcl::PointCloud<pcl::PointXYZ>& ours,
                 const std::vector<Eigen::Vector3f>& pcl_points,
                 const std::string& what)
{
  ASSERT_EQ(ours.size(), pcl_points.size()) << what;
  for (std::size_t i = 0; i < ours.size(); ++i)
    ASSERT_EQ(ours[i].getVector3fMap(), pcl_points[i]) << what << " point " << i;
}

// Our PCD reader against PCL's on what pcl::PCDWriter writes: the three encodings, point
// types with further fields and padding ("_" in PointXYZRGBNormal's binary layout), NaN
// points, an organised cloud; bit-identical coordinates, the same points in order.
TEST_F(TempFiles, PcdReaderMatchesPclOnWhatPclWrites)
{
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-50.0f, 50.0f);
  pcl::PointCloud<pcl::PointXYZRGBNormal> rich;
  rich.width = 37;
  rich.height = 3; // organised
  for (std::size_t i = 0; i < 111; ++i) {
    pcl::PointXYZRGBNormal p;
    p.x = i % 17 == 5 ? kNaN : u(rng);
    p.y = u(rng);
    p.z = u(rng);
    p.normal_x = u(rng);
    p.rgba = static_cast<std::uint32_t>(rng());
    rich.push_back(p);
  }
  rich.width = 37;
  rich.height = 3;
  pcl::PointCloud<pcl::PointXYZI> plain;
  for (std::size_t i = 0; i < 50; ++i) {
    pcl::PointXYZI p;
    p.x = u(rng);
    p.y = u(rng);
    p.z = i == 7 ? std::numeric_limits<float>::infinity() : u(rng);
    p.intensity = u(rng);
    plain.push_back(p);
  }
  pcl::PCDWriter writer;
  for (int mode = 0; mode < 3; ++mode) {
    const std::string tag = std::to_string(mode);
    const auto rich_path = (dir_ / ("rich" + tag + ".pcd")).string();
    const auto plain_path = (dir_ / ("plain" + tag + ".pcd")).string();
    if (mode == 0) {
      ASSERT_EQ(writer.writeASCII(rich_path, rich, 9), 0);
      ASSERT_EQ(writer.writeASCII(plain_path, plain, 9), 0);
    }
    else if (mode == 1) {
      ASSERT_EQ(writer.writeBinary(rich_path, rich), 0);
      ASSERT_EQ(writer.writeBinary(plain_path, plain), 0);
    }
    else {
      ASSERT_EQ(writer.writeBinaryCompressed(rich_path, rich), 0);
      ASSERT_EQ(writer.writeBinaryCompressed(plain_path, plain), 0);
    }
    for (const auto& path : {rich_path, plain_path}) {
      const auto expected = pclPoints(path);
      ASSERT_GT(expected.size(), 40u) << path;
      expectSamePoints(*loadScan(path), expected, path);
    }
  }
}

// The same on the PCL test clouds in the shared data (ascii with normals, binary with
// intensity, binary_compressed with rgba).
TEST(PcdReader, MatchesPclOnPclsTestClouds)
{
  for (const char* name : {"pcl_test/bun0.pcd",
                           "pcl_test/bunny.pcd",
                           "pcl_test/milk_color.pcd",
                           "pcl_test/office1_keypoints.pcd"}) {
    PCL_PARALLEL_REQUIRE_DATA(path, name);
    const auto expected = pclPoints(path);
    ASSERT_GT(expected.size(), 100u) << path;
    expectSamePoints(*loadScan(path), expected, path);
  }
}

// Our PLY reader against PCL's on what pcl::PLYWriter writes (ascii and binary, further
// vertex properties, the camera element after the vertices) and on the Stanford scans
// (ascii, obj_info lines, a range_grid list element after the vertices).
TEST_F(TempFiles, PlyReaderMatchesPclOnWhatPclWritesAndTheBunny)
{
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-50.0f, 50.0f);
  pcl::PointCloud<pcl::PointXYZRGBNormal> rich;
  for (std::size_t i = 0; i < 60; ++i) {
    pcl::PointXYZRGBNormal p;
    p.x = i == 9 ? kNaN : u(rng);
    p.y = u(rng);
    p.z = u(rng);
    p.normal_z = u(rng);
    p.rgba = static_cast<std::uint32_t>(rng());
    rich.push_back(p);
  }
  for (bool binary : {false, true}) {
    const auto path = (dir_ / (binary ? "rich_binary.ply" : "rich_ascii.ply")).string();
    ASSERT_EQ(pcl::io::savePLYFile(path, rich, binary), 0);
    const auto expected = pclPoints(path);
    ASSERT_EQ(expected.size(), 59u) << path;
    expectSamePoints(*loadScan(path), expected, path);
  }
  PCL_PARALLEL_REQUIRE_DATA(bunny, "stanford_bunny/bun000.ply");
  const auto expected = pclPoints(bunny);
  ASSERT_GT(expected.size(), 40000u);
  expectSamePoints(*loadScan(bunny), expected, bunny);
}

// What PCL's writer does not write: big-endian, double coordinates, a face list element
// before the vertices (skipped by its declared layout), and the same in ascii.
/** A PCL blob of float32 x, y, z and further scalar fields `extra` (name, PCL datatype),
 *  `n` points of value(i, field) each, field 0-2 the coordinates. */
template <typename Value>
pcl::PCLPointCloud2
blob(std::size_t n, const std::vector<std::pair<std::string, std::uint8_t>>& extra, Value value)
{
  pcl::PCLPointCloud2 c;
  std::vector<std::pair<std::string, std::uint8_t>> fields = {
      {"x", pcl::PCLPointField::FLOAT32},
      {"y", pcl::PCLPointField::FLOAT32},
      {"z", pcl::PCLPointField::FLOAT32}};
  fields.insert(fields.end(), extra.begin(), extra.end());
  std::uint32_t offset = 0;
  for (const auto& [name, type] : fields) {
    pcl::PCLPointField f;
    f.name = name;
    f.offset = offset;
    f.datatype = type;
    f.count = 1;
    c.fields.push_back(f);
    offset += static_cast<std::uint32_t>(pcl::getFieldSize(type));
  }
  c.point_step = offset;
  c.width = static_cast<std::uint32_t>(n);
  c.height = 1;
  c.row_step = c.point_step * c.width;
  c.data.resize(c.row_step);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t f = 0; f < fields.size(); ++f) {
      unsigned char* at = &c.data[i * c.point_step + c.fields[f].offset];
      const double v = value(i, f);
      if (fields[f].second == pcl::PCLPointField::FLOAT32) {
        const float x = static_cast<float>(v);
        std::memcpy(at, &x, sizeof x);
      }
      else if (fields[f].second == pcl::PCLPointField::FLOAT64)
        std::memcpy(at, &v, sizeof v);
      else { // UINT32
        const auto u = static_cast<std::uint32_t>(v);
        std::memcpy(at, &u, sizeof u);
      }
    }
  return c;
}

// Per-point times as drivers write them: Ouster's "t" (uint32 ns) beside an absolute
// "timestamp" (float64) it is preferred to, in the three PCD encodings PCL writes; NaN
// points and the range filter drop their times with them, in point order.
TEST_F(TempFiles, PcdReaderKeepsEachPointsTime)
{
  const std::size_t n = 20;
  const auto value = [](std::size_t i, std::size_t f) {
    switch (f) {
    case 0:
      return i == 5 ? std::nan("") : static_cast<double>(i); // range i along x
    case 1:
    case 2:
      return 0.0;
    case 3:
      return 1000.0 * static_cast<double>(i) + 7.0; // t [ns]
    default:
      return 1.7e9 + 0.001 * static_cast<double>(i); // timestamp [s]
    }
  };
  const auto both =
      blob(n,
           {{"t", pcl::PCLPointField::UINT32}, {"timestamp", pcl::PCLPointField::FLOAT64}},
           value);
  const auto absolute = blob(n,
                             {{"timestamp", pcl::PCLPointField::FLOAT64}},
                             [&](auto i, auto f) { return value(i, f == 3 ? 4 : f); });
  pcl::PCDWriter writer;
  for (int mode = 0; mode < 3; ++mode) {
    SCOPED_TRACE("encoding " + std::to_string(mode));
    const auto path = [&](const char* name) {
      return (dir_ / (name + std::to_string(mode) + ".pcd")).string();
    };
    const auto write = [&](const std::string& file, const pcl::PCLPointCloud2& c) {
      if (mode == 0)
        return writer.writeASCII(
            file, c, Eigen::Vector4f::Zero(), Eigen::Quaternionf::Identity(), 17);
      return mode == 1 ? writer.writeBinary(file, c) : writer.writeBinaryCompressed(file, c);
    };
    ASSERT_EQ(write(path("both"), both), 0);
    ASSERT_EQ(write(path("absolute"), absolute), 0);
    std::vector<double> times = {42.0};
    const auto cloud = loadScan(path("both"), 1.5, 1e9, &times);
    ASSERT_EQ(cloud->size(), n - 3); // 0, 1 out of range, 5 not finite
    ASSERT_EQ(times.size(), cloud->size());
    for (std::size_t k = 0; k < cloud->size(); ++k) {
      const auto i = static_cast<std::size_t>((*cloud)[k].x);
      EXPECT_EQ(times[k], value(i, 3)) << "point " << k;
    }
    loadScan(path("absolute"), 1.5, 1e9, &times);
    ASSERT_EQ(times.size(), n - 3);
    EXPECT_NEAR(times.back() - times.front(), 0.001 * 17, 1e-6); // 2 .. 19
    // Times not asked for: as before; point 0 lies at the origin, a no-return.
    EXPECT_EQ(loadScan(path("both"))->size(), n - 2);
  }
}

// PLY: a vertex property named as a time field, in ASCII and binary; a kept point whose
// time is not a number is an error naming the file and line, a dropped one is not.
TEST_F(TempFiles, PlyReaderKeepsEachPointsTimeAndRejectsNonFiniteOnes)
{
  const std::string header = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n"
                             "property float y\nproperty float z\nproperty double time\n"
                             "end_header\n";
  std::vector<double> times;
  loadScan(write("a.ply", header + "1 0 0 0.25\nnan 0 0 nan\n2 0 0 0.5\n"), 0.0, 1e9, &times);
  EXPECT_EQ(times, (std::vector<double>{0.25, 0.5}));
  const std::string bad = write("bad.ply", header + "1 0 0 0.25\n2 0 0 nan\n3 0 0 1\n");
  const std::string message =
      messageOf<std::runtime_error>([&] { loadScan(bad, 0.0, 1e9, &times); });
  EXPECT_TRUE(mentions(message, bad + ":10")) << message;
  EXPECT_TRUE(mentions(message, "time")) << message;
  EXPECT_EQ(loadScan(bad)->size(), 3u); // without times, the time is not read
  // Little-endian binary, Ouster's uint32 "t" after the coordinates.
  std::string binary = "ply\nformat binary_little_endian 1.0\nelement vertex 2\n"
                       "property float x\nproperty float y\nproperty float z\n"
                       "property uint t\nend_header\n";
  for (const std::uint32_t i : {1u, 2u}) {
    const float xyz[3] = {static_cast<float>(i), 0, 0};
    const std::uint32_t t = 50000000u * i;
    binary.append(reinterpret_cast<const char*>(xyz), sizeof xyz);
    binary.append(reinterpret_cast<const char*>(&t), sizeof t);
  }
  loadScan(write("b.ply", binary), 0.0, 1e9, &times);
  EXPECT_EQ(times, (std::vector<double>{5e7, 1e8}));
  // Formats without per-point times leave none.
  loadScan(write("c.xyz", "1 2 3\n"), 0.0, 1e9, &times);
  EXPECT_TRUE(times.empty());
}

TEST_F(TempFiles, PlyReaderSkipsElementsByTheirLayout)
{
  const auto be32 = [](std::uint32_t v) {
    return std::string{static_cast<char>(v >> 24),
                       static_cast<char>(v >> 16),
                       static_cast<char>(v >> 8),
                       static_cast<char>(v)};
  };
  const auto be64 = [&](double d) {
    std::uint64_t v;
    std::memcpy(&v, &d, sizeof v);
    return be32(static_cast<std::uint32_t>(v >> 32)) + be32(static_cast<std::uint32_t>(v));
  };
  std::string big = "ply\nformat binary_big_endian 1.0\ncomment faces first\n"
                    "element face 2\nproperty list uchar int vertex_indices\n"
                    "element vertex 2\nproperty double x\nproperty ushort tag\n"
                    "property double y\nproperty double z\nend_header\n";
  big += std::string(1, '\3') + be32(0) + be32(1) + be32(0); // a triangle
  big += std::string(1, '\0');                               // an empty face
  big += be64(1.5) + std::string("\0\7", 2) + be64(-2.25) + be64(1e-3);
  big += be64(4) + std::string("\0\7", 2) + be64(5) + be64(6);
  const auto from_big = loadScan(write("big.ply", big));
  ASSERT_EQ(from_big->size(), 2u);
  expectPoint((*from_big)[0], 1.5f, -2.25f, 1e-3f);
  expectPoint((*from_big)[1], 4, 5, 6);
  const auto from_text = loadScan(write("faces.ply",
                                        "ply\nformat ascii 1.0\nelement face 2\n"
                                        "property list uchar int vertex_indices\n"
                                        "element vertex 2\nproperty float x\nproperty int tag\n"
                                        "property float y\nproperty float z\nend_header\n"
                                        "3 0 1 0\n0\n1.5 7 -2.25 0.001\n4 7 5 6\n"));
  ASSERT_EQ(from_text->size(), 2u);
  expectPoint((*from_text)[0], 1.5f, -2.25f, 1e-3f);
  // The data ending inside the vertices, or a line with a value too few or too many,
  // is an error naming the file.
  for (const std::string& bad :
       {big.substr(0, big.size() - 3),
        std::string("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
                    "property float y\nproperty float z\nend_header\n1 2 3\n4 5\n"),
        std::string("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                    "property float y\nproperty float z\nend_header\n1 2 3 4\n")}) {
    const auto path = write("bad.ply", bad);
    EXPECT_TRUE(mentions(messageOf<std::runtime_error>([&] { loadScan(path); }), path));
  }
}

TEST_F(TempFiles, LoadScanRejectsPcdWithoutFloatXyz)
{
  const std::string header = "VERSION 0.7\n"
                             "FIELDS x y z\n";
  const std::string tail = "COUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
                           "POINTS 1\nDATA ascii\n1 2 3\n";
  // Sanity check: the same file with float32 fields reads.
  const auto ok = loadScan(write("float.pcd", header + "SIZE 4 4 4\nTYPE F F F\n" + tail));
  ASSERT_EQ(ok->size(), 1u);
  expectPoint((*ok)[0], 1, 2, 3);
  // float64 coordinates read too (pcl::fromPCLPointCloud2 left them at the origin).
  const auto doubles =
      loadScan(write("double.pcd", header + "SIZE 8 8 8\nTYPE F F F\n" + tail));
  ASSERT_EQ(doubles->size(), 1u);
  expectPoint((*doubles)[0], 1, 2, 3);
  const auto integers = write("integer.pcd", header + "SIZE 4 4 4\nTYPE I F F\n" + tail);
  EXPECT_TRUE(mentions(messageOf<std::runtime_error>([&] { loadScan(integers); }), "\"x\""));
  const auto no_z =
      write("no_z.pcd", "VERSION 0.7\nFIELDS x y intensity\nSIZE 4 4 4\nTYPE F F F\n" + tail);
  EXPECT_TRUE(mentions(messageOf<std::runtime_error>([&] { loadScan(no_z); }), "\"z\""));
}

TEST(ScanIo, IsScanFileFollowsTheExtension)
{
  for (const char* yes : {"a.3d", "b.xyz", "c.txt", "d.bin", "e.pcd", "f.ply", "dir/G.PLY"})
    EXPECT_TRUE(isScanFile(yes)) << yes;
  for (const char* no : {"a.las", "b.pose", "pcd", ".pcd", "scan.pcd.gz", "dir.pcd/readme", ""})
    EXPECT_FALSE(isScanFile(no)) << no;
}

TEST(UosData, LoadScanEqualsLoadUosScan)
{
  PCL_PARALLEL_REQUIRE_DATA(scan, "3dtk_dat/scan000.3d");
  const auto direct = loadUosScan(scan, 50.0, 3000.0);
  const auto dispatched = loadScan(scan, 50.0, 3000.0);
  ASSERT_GT(direct->size(), 1000u);
  ASSERT_LT(direct->size(), 81360u); // the range filter did drop points
  ASSERT_EQ(dispatched->size(), direct->size());
  for (std::size_t i = 0; i < direct->size(); ++i)
    ASSERT_EQ((*dispatched)[i].getVector3fMap(), (*direct)[i].getVector3fMap()) << i;
}

// ---------------------------------------------------------------------------------------
// Issue 11: what the readers did wrong, each with the test that would have caught it.

/** A decimal comma for the C++ global locale: iostreams (the old uos parser) read "1.5" as
 *  1 under it; from_chars does not look at any locale. */
struct CommaDecimal : std::numpunct<char> {
  char
  do_decimal_point() const override
  {
    return ',';
  }
};

TEST_F(TempFiles, TextFormatsIgnoreTheGlobalLocale)
{
  const std::locale saved = std::locale::global(std::locale(std::locale(), new CommaDecimal));
  const auto uos = loadUosScan(write("l.3d", "1.5 2.25 -3.5\n"));
  const auto pose = loadUosPose(write("l.pose", "1.5 2.5 3.5\n0.0 0.0 0.0\n"));
  const auto frames =
      loadFramesFinalPose(write("l.frames", "1 0 0 0 0 1 0 0 0 0 1 0 1.5 2.5 3.5 1 2\n"));
  const auto xyz = loadXyzScan(write("l.xyz", "1.5 2.25 -3.5\n"));
  const auto kitti = loadKittiPoses(write("l.txt", "1 0 0 1.5 0 1 0 2.5 0 0 1 3.5\n"));
  const auto conf =
      pcl_parallel::io::loadStanfordConf(write("l.conf", "bmesh a.ply 1.5 2.5 3.5 0 0 0 1\n"));
  std::locale::global(saved);
  ASSERT_EQ(uos->size(), 1u);
  expectPoint((*uos)[0], 1.5f, 2.25f, -3.5f);
  expectPoint((*xyz)[0], 1.5f, 2.25f, -3.5f);
  const Eigen::Vector3d t(1.5, 2.5, 3.5);
  EXPECT_EQ(Eigen::Vector3d(pose.topRightCorner<3, 1>()), t);
  EXPECT_EQ(Eigen::Vector3d(frames.topRightCorner<3, 1>()), t);
  EXPECT_EQ(Eigen::Vector3d(kitti.at(0).topRightCorner<3, 1>()), t);
  EXPECT_EQ(Eigen::Vector3d(conf.at(0).pose.topRightCorner<3, 1>()), t);
}

TEST_F(TempFiles, UosEmptyHeaderOnlyAndGarbledLinesAreErrors)
{
  for (const char* content : {"", "\n  \n", "360 x 225\n"}) {
    const auto path = write("empty.3d", content);
    EXPECT_TRUE(
        mentions(messageOf<std::runtime_error>([&] { loadUosScan(path); }), "no points"))
        << quoted(content);
  }
  // Only 3DTK's "W x H" grid header is skipped, and only as the first line: garbled
  // lines before the data are errors with their line number, not a silent "header".
  const auto garbled = write("garbled.3d", "1 2 x3\n4 5 6\n");
  EXPECT_TRUE(
      mentions(messageOf<std::runtime_error>([&] { loadUosScan(garbled); }), "garbled.3d:1:"));
  const auto second = write("second.3d", "360 x 225\n\nabc\n4 5 6\n");
  EXPECT_TRUE(
      mentions(messageOf<std::runtime_error>([&] { loadUosScan(second); }), "second.3d:3:"));
  const auto late = write("late.3d", "4 5 6\n360 x 225\n");
  EXPECT_TRUE(
      mentions(messageOf<std::runtime_error>([&] { loadUosScan(late); }), "late.3d:2:"));
  // A scan whose points are all out of range is an empty cloud, not an error.
  EXPECT_TRUE(loadUosScan(write("far.3d", "3276.7 0 0\n"), 0.0, 3000.0)->empty());
  // Other 3DTK files: every line is checked, empty files are errors.
  EXPECT_THROW(loadFramesFinalPose(write("e.frames", "")), std::runtime_error);
  const auto mid = write("mid.frames",
                         "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 2\ngarbage\n"
                         "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 2\n");
  EXPECT_TRUE(mentions(messageOf<std::runtime_error>([&] { loadFramesFinalPose(mid); }),
                       "mid.frames:2:"));
  EXPECT_THROW(loadUosPose(write("long.pose", "1 2 3\n4 5 6 7\n")), std::runtime_error);
  EXPECT_THROW(loadUosPose(write("nan.pose", "1 2 3\n4 5 nan\n")), std::runtime_error);
}

TEST_F(TempFiles, CoordinatesBeyondFloatAreErrorsNotInf)
{
  // 1e39 is finite as a double and inf as a float: it must not enter a "dense" cloud.
  for (const char* name : {"big.3d", "big.xyz"}) {
    const auto path = write(name, "1 2 3\n1e39 0 0\n");
    const std::string msg = messageOf<std::runtime_error>([&] { loadScan(path); });
    EXPECT_TRUE(mentions(msg, std::string(name) + ":2:")) << msg;
    EXPECT_TRUE(mentions(msg, "float")) << msg;
    // Outside the range filter it is dropped like any far point, before narrowing.
    const auto near = loadScan(path, 0.0, 100.0);
    ASSERT_EQ(near->size(), 1u);
    EXPECT_TRUE(near->getMatrixXfMap(3, 4, 0).allFinite());
  }
}

TEST_F(TempFiles, BinaryGarbageGivesAShortMessage)
{
  std::string garbage(100000, '\0');
  std::mt19937 rng(11);
  for (char& c : garbage) {
    c = static_cast<char>(rng() & 0xff);
    if (c == '\n')
      c = 'n';
  }
  for (const char* name : {"g.xyz", "g.3d", "g.pose", "g.frames", "g.conf"}) {
    const auto path = write(name, garbage);
    std::string msg;
    try {
      if (mentions(name, ".pose"))
        loadUosPose(path);
      else if (mentions(name, ".frames"))
        loadFramesFinalPose(path);
      else if (mentions(name, ".conf"))
        pcl_parallel::io::loadStanfordConf(path);
      else
        loadScan(path);
      ADD_FAILURE() << name << ": no exception";
    }
    catch (const std::runtime_error& e) {
      msg = e.what();
    }
    EXPECT_TRUE(mentions(msg, path)) << msg;
    EXPECT_LT(msg.size(), path.size() + 320) << msg; // 40 bytes, escaped
    for (char c : msg)                               // printable: the bytes are escaped
      ASSERT_TRUE(c == '\n' || (static_cast<unsigned char>(c) >= 0x20)) << name;
  }
}

// PCD headers whose layout PCL 1.13's readHeader derives wrongly (found by the fuzz
// stage in CI: its ASCII reader then wrote past the points, and the heap damage showed as
// a bad free much later). PCL is not instrumented, so the check must reject them.
TEST_F(TempFiles, PcdHeadersPclMisplacesAreRejected)
{
  const std::string head = "VERSION 0.7\nFIELDS x y z\n";
  const std::string tail = "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 3\n4 5 6\n";
  const std::pair<const char*, std::string> bad[] = {
      // Placed by SIZE (8 bytes a point) but written as three float32 (12).
      {"size_without_type", head + "SIZE 4 4 0\n" + tail},
      {"size_against_type", head + "SIZE 4 4 2\nTYPE F F F\nCOUNT 1 1 1\n" + tail},
      {"unknown_type", head + "SIZE 4 4 3\nTYPE F F F\nCOUNT 1 1 1\n" + tail},
      // A second FIELDS after SIZE: readHeader read SIZE values out of bounds.
      {"second_fields", head + "SIZE 4 4 4\nFIELDS x y z w\nTYPE F F F F\n" + tail},
      {"size_before_fields", "VERSION 0.7\nSIZE 4 4 4\nFIELDS x y z\n" + tail},
      {"second_points", head + "SIZE 4 4 4\nTYPE F F F\nPOINTS 9\n" + tail}};
  for (const auto& [name, text] : bad) {
    const auto pcd = write(std::string(name) + ".pcd", text);
    const std::string msg = messageOf<std::runtime_error>([&] { loadScan(pcd); });
    EXPECT_TRUE(mentions(msg, pcd)) << name << ": " << msg;
    EXPECT_TRUE(mentions(msg, "PCD header")) << name << ": " << msg;
  }
  // The same points with a consistent header, and PCD v0.5's FIELDS-only header (all
  // float32), still read.
  for (const std::string& good :
       {head + "SIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n" + tail, head + tail}) {
    const auto cloud = loadScan(write("good.pcd", good));
    ASSERT_EQ(cloud->size(), 2u);
    EXPECT_EQ((*cloud)[1].getVector3fMap(), Eigen::Vector3f(4, 5, 6));
  }
}

TEST_F(TempFiles, HugePointCountsAreClearErrorsBeforeAllocation)
{
  // Headers that claim 4e9 points in a file of a few hundred bytes: PCL would allocate
  // for them (std::bad_alloc, or the OOM killer on an overcommitting system).
  for (const char* data : {"ascii", "binary", "binary_compressed"}) {
    const auto pcd = write(std::string("huge_") + data + ".pcd",
                           std::string("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\n"
                                       "COUNT 1 1 1\nWIDTH 4000000000\nHEIGHT 1\n"
                                       "POINTS 4000000000\nDATA ") +
                               data + "\n1 2 3\n");
    const std::string msg = messageOf<std::runtime_error>([&] { loadScan(pcd); });
    EXPECT_TRUE(mentions(msg, pcd)) << msg;
    EXPECT_TRUE(mentions(msg, "4000000000")) << msg;
  }
  for (const char* format : {"ascii", "binary_little_endian"}) {
    const auto ply = write(std::string("huge_") + format + ".ply",
                           std::string("ply\nformat ") + format +
                               " 1.0\nelement vertex 4000000000\nproperty float x\n"
                               "property float y\nproperty float z\nend_header\n1 2 3\n");
    const std::string msg = messageOf<std::runtime_error>([&] { loadScan(ply); });
    EXPECT_TRUE(mentions(msg, ply)) << msg;
    EXPECT_TRUE(mentions(msg, "elements")) << msg;
  }
}

TEST_F(TempFiles, KittiScanRejectsWhatIsNotFloat32Records)
{
  // Random bytes of a multiple of 16: values beyond 1e5 (or inf/NaN patterns) appear.
  std::string garbage(1600, '\0');
  std::mt19937 rng(12);
  for (char& c : garbage)
    c = static_cast<char>(rng() & 0xff);
  EXPECT_TRUE(
      mentions(messageOf<std::runtime_error>([&] { loadKittiScan(write("r.bin", garbage)); }),
               "plausible"));
  // Text: its bytes are tiny floats.
  std::string text;
  while (text.size() < 1600)
    text += "12.5 -3.25 0.5 1\n";
  text.resize(1600);
  EXPECT_TRUE(mentions(
      messageOf<std::runtime_error>([&] { loadKittiScan(write("t.bin", text)); }), "1 mm"));
  // A PCD or PLY renamed to .bin.
  std::string pcd = "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\n";
  pcd.resize(64, ' ');
  EXPECT_THROW(loadKittiScan(write("p.bin", pcd)), std::runtime_error);
  std::string ply = "ply\nformat binary_little_endian 1.0\n";
  ply.resize(64, ' ');
  EXPECT_THROW(loadKittiScan(write("y.bin", ply)), std::runtime_error);
  // NaN and inf mark a no-return as in every format: dropped.
  EXPECT_EQ(
      loadKittiScan(write("inf.bin", kittiBytes({1, 2, 3, 0, 1, 2, INFINITY, 0, NAN, 1, 1, 0})))
          ->size(),
      1u);
  // Real-looking records, including a point at the origin and one close by, still read
  // (the one at the origin dropped: a driver's no-return).
  EXPECT_EQ(loadKittiScan(
                write("ok.bin",
                      kittiBytes({0, 0, 0, 0, 0.0005f, 0.0005f, 0.0005f, 0.1f, 90, -40, 2, 1})))
                ->size(),
            2u);
}

TEST_F(TempFiles, StanfordConfRejectsGarbledAndEmptyFiles)
{
  const auto ok = write("ok.conf",
                        "camera 0 0 -1 0 0 0 1\n\nbmesh a.ply 1 2 3 0 0 0 1\n"
                        "bmesh b.ply 0 0 0 0 0 0.7071068 0.7071068\n");
  const auto entries = pcl_parallel::io::loadStanfordConf(ok);
  ASSERT_EQ(entries.size(), 2u);
  EXPECT_EQ(entries[1].file, "b.ply");
  EXPECT_NEAR(entries[1].pose(1, 0), -1.0, 1e-6);                // R(q)^T of 90 deg about z
  for (const char* bad : {"bmesh a.ply 1 2 3 0 0 0\n",           // 6 numbers
                          "bmesh a.ply 1 2 3 0 0 0 1 9\n",       // 8
                          "bmesh a.ply 1 2 3 0 0 0 0\n",         // zero quaternion
                          "bmesh a.ply 1 2 nan 0 0 0 1\n",       // not finite
                          "bmesh a.ply 1 2 3 0 0 0 1\nbmsh b\n", // unknown keyword
                          "",
                          "camera 0 0 0 0 0 0 1\n"}) { // no bmesh line
    const auto path = write("bad.conf", bad);
    EXPECT_TRUE(mentions(
        messageOf<std::runtime_error>([&] { pcl_parallel::io::loadStanfordConf(path); }), path))
        << bad;
  }
}

TEST_F(TempFiles, EmptyXyzIsAnError)
{
  for (const char* content : {"", "# only a comment\n\n"}) {
    const auto path = write("empty.xyz", content);
    EXPECT_TRUE(mentions(messageOf<std::runtime_error>([&] { loadScan(path); }), "no points"))
        << quoted(content);
  }
}

// A path through a file (ENOTDIR) and, unless running as root (which reads anything), a
// file and a directory without read permission: errors naming the path, no crash.
TEST_F(TempFiles, UnreadablePathsAreErrors)
{
  const auto file = write("plain.txt", "1 2 3\n");
  const std::string through = file + "/scan.3d";
  EXPECT_TRUE(mentions(messageOf<std::runtime_error>([&] { loadScan(through); }), through));
  EXPECT_THROW(loadUosPose(file + "/scan.pose"), std::runtime_error);
  if (::geteuid() == 0)
    GTEST_SKIP() << "running as root: permission bits do not stop reads";
  const auto locked = write("locked.xyz", "1 2 3\n");
  std::filesystem::permissions(locked, std::filesystem::perms::none);
  EXPECT_TRUE(mentions(messageOf<std::runtime_error>([&] { loadScan(locked); }), locked));
  const auto dir = dir_ / "locked_dir";
  std::filesystem::create_directories(dir);
  const auto inside = (dir / "scan.3d").string();
  std::ofstream(inside) << "1 2 3\n";
  std::filesystem::permissions(dir, std::filesystem::perms::none);
  EXPECT_TRUE(mentions(messageOf<std::runtime_error>([&] { loadScan(inside); }), inside));
  std::filesystem::permissions(dir, std::filesystem::perms::owner_all); // for TearDown
}

// Fuzz-stage findings (scripts/test.sh fuzz), each kept as a regression: damaged PCD/PLY
// files that PCL parses into a blob with no points or fewer bytes than points, which
// pcl::fromPCLPointCloud2 then indexed out of bounds (UBSan: reference binding to null),
// and a compressed PCD whose size word made PCL allocate 1.8 GB.
// The asan stage runs these under UBSan. The readers must throw or return a dense cloud.
TEST_F(TempFiles, FuzzFindingsAreHandled)
{
  const std::pair<const char*, std::string> findings[] = {
      {"pcd_crash_e591fd5f.pcd",
       std::string(
           "# .PCD v0\000\340\077\000\000\000@\000.7 -\340\245oint Cloud Data file format\012"
           "VERSION 1.7\012FIELDS x y z\012SIZE 4 4 4\012TYPE F F F\012CO\376\377\377\367UNT"
           " 1 1 1\012WIDTH 6\012\301\272IGHT 1\012VIEWPOINT 0 0 0 1 0 0 0\012POINTS 6\012DA"
           "TA ascii\0120 -1.25 2\0120.5 -0.25 2\0121 0.75; 2\0121>5 1.75 2\0122 2.75 2\012n"
           "an 0 0\012",
           235)},
      // binary_compressed with an uncompressed size word of 1.8 GB: PCL allocated it.
      {"pcd_oom_fc3be2d1.pcd",
       std::string(
           "# .PCD v0.7 - Point Cloud Data file format\012VERSION 0.7\012FIELDS x y z\012SIZ"
           "E 4 4 4\012TYPE F F F\012COUNT 1 1 1\012WIDTH 6\012HEIGHT 1\012VIEWPOINT 0 0 0 1"
           " 0 0 0\012POINTS 6\012DATA binary_compressed\0125\000\000\000H\000\000le format\012"
           "VERSION 0.7\012FIELDS x y z0 0 1 0 0 0\012PO\340\006\003\001\000\000",
           236)},
      {"ply_crash_2f3b6d30.ply",
       std::string(
           "ply\012format binary_little_endian 1.0\012comment PCL generated\012element verte"
           "x 6\012property float x\012property float y\012property float z\012element face "
           "0\012element camera 1\012property float view_px\012property float view_py\012pro"
           "perty float view_pz\012property float x_axisx\012property float x_axisy\012prope"
           "rty float x_axisz\012property float y_axisx\012property float y_axisy\012propert"
           "y float y_axisz\012property float z_axisx\012property float z_axisy\012prop%rty "
           "float z_axisz\012property float focal\012property float scalex\012property float"
           " scaley\012property float centerx\012property float centery\012property int view"
           "portx\012property int viewporty\012property float k1\012property float k2\012end"
           "_header\012\000\000\000\000\000\000\240\277\000\000\000@\000\000\000\077\000\000"
           "\200\276\000\000\000@\000\000\200\077\000\000@\077\000\000\000@\000\000\300\077\000"
           "\000\340\077\000\000\000@\000\000\000@\000\0000@\000\000\000@\000\000\300\177\000"
           "\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000"
           "\000\200\077\000\000\000\000\000\000\000\000\000\000\000\000\000\000\200\077\000"
           "\000\000\000\000\000\000\000\000\000\000\000\000\000\200\077\000\000\000\000\000"
           "\000\000\000\000\000\000\000\000\000\000\000\000\000\000\000\006\000\000\000\001"
           "\000\000\000\000\000\000\000\000\000\000\000",
           794)},
      // An "obj_info" line after carriage returns: PCL's PLY parser failed an assert
      // (abort) on it.
      {"ply_crash_3d68cfc4.ply",
       std::string(
           "ply\012formak binary\200\077\000\000\000 int vie\012\012\012\012\012\012\012"
           "\012\012\012\012\000\300\177\000\000\000\020'\000\000ie\012\012\000\000\000"
           "\012\012\012\012\334\002\012\012\012St9bad_allocformat binary\200\077:\000\000"
           " int\265\265\265\265\265\265\265\265\265 vie\012\012\012\012\012\012\012\012"
           "\012\012\366\365\365\365\365\365\365\365\012\012z_axi\012z\012\012\012s\012"
           "\012\012\012\012\012\000\300\177\000\000\000\020'\000\000ie\012\012\000\000"
           "\012\012\012\012\012\012\012\012\012*\012\366\365\365\365\365\365\365\365\012"
           "\000\000\012\015\015\015\015\015\015\015\015\015\015\015\015\015obj_info\015"
           "\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015"
           "\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015"
           "\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015"
           "\015\015\015\015\015\015e\012\015\015\015\015\015\015\015\015\015\015\015\015"
           "\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\000\000z"
           "\012\012.ply\012\012\012\012\012\012\012\012\000\300\177\000\000\000\374'\000"
           "\000ie\012\012\000\000\012\012\012\015\015\015\015\015\015\015\015\015\015\015"
           "\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015\015"
           "\015\015\015\015\015\015\015\015\015\015\000\000z\012\012.ply\012\012e\012\012"
           "\000\000\012\012\012\012\012\012\012\012\012\012\012\366\365\365\365\365\365"
           "\365\365\012\000\000\374\377\000\000z_\000\000\000\000\000",
           431)},
      // An element without properties but a count of 8e18: PCL's parser looped over it
      // (a hang; the header check skipped elements without properties).
      {"ply_timeout_9847e72f.ply",
       "ply\nformat binary_little_endian 1.0\nelement vertex888 8174784388664859760\n"
       "element face 0\nend_header\n"}};
  for (const auto& [name, bytes] : findings) {
    const auto path = write(name, bytes);
    try {
      const auto cloud = loadScan(path);
      EXPECT_TRUE(cloud->is_dense) << name;
      EXPECT_EQ(cloud->width, cloud->size()) << name;
      for (const auto& p : *cloud)
        ASSERT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) << name;
    }
    catch (const std::runtime_error& e) {
      EXPECT_TRUE(mentions(e.what(), path)) << e.what();
    }
  }
}

// The poses a mapping run leaves: scanNNN.frames per scan (initial INVALID, ICP, final LUM;
// the fixed first scan ICPINACTIVE; translations in the frames' unit), KITTI and TUM files
// of the final and the front end's poses; a callback after each .frames file.
TEST_F(TempFiles, RunPosesAreFramesKittiAndTum)
{
  std::vector<Eigen::Matrix4d> initial, icp, final_poses;
  for (int i = 0; i < 3; ++i) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitZ()).matrix();
    m(0, 3) = i;
    initial.push_back(m);
    m(1, 3) = 0.25;
    icp.push_back(m);
    m(2, 3) = -0.5;
    final_poses.push_back(m);
  }
  const std::vector<int> numbers = {7, 8, 1234};
  const std::vector<double> stamps = {0.5, 1.0, 1.5};
  int files = 0;
  const auto names = writeRunPoses(
      dir_.string(), numbers, initial, icp, final_poses, stamps, 0.01, [&] { ++files; });
  EXPECT_EQ(files, 3);
  EXPECT_EQ(names,
            (std::vector<std::string>{"scanNNN.frames",
                                      "poses.txt",
                                      "poses_icp.txt",
                                      "poses_tum.txt",
                                      "poses_icp_tum.txt"}));
  for (std::size_t i = 0; i < 3; ++i) {
    const std::string name =
        i < 2 ? "scan00" + std::to_string(numbers[i]) + ".frames" : "scan1234.frames";
    const auto history = loadFrames((dir_ / name).string(), 0.01);
    ASSERT_EQ(history.size(), 3u) << name;
    EXPECT_LT((history[0] - initial[i]).norm(), 1e-9) << name;
    EXPECT_LT((history[1] - icp[i]).norm(), 1e-9) << name;
    EXPECT_LT((history[2] - final_poses[i]).norm(), 1e-9) << name;
    std::ifstream in(dir_ / name);
    std::vector<int> types;
    for (std::string line; std::getline(in, line);)
      types.push_back(std::stoi(line.substr(line.find_last_of(' ') + 1)));
    EXPECT_EQ(types,
              (i == 0 ? std::vector<int>{kFramesInvalid, kFramesIcpInactive, kFramesIcpInactive}
                      : std::vector<int>{kFramesInvalid, kFramesIcp, kFramesLum}))
        << name;
  }
  EXPECT_EQ(loadKittiPoses((dir_ / "poses.txt").string()), final_poses);
  EXPECT_EQ(loadKittiPoses((dir_ / "poses_icp.txt").string()), icp);
  const Trajectory tum = loadTumTrajectory((dir_ / "poses_icp_tum.txt").string());
  EXPECT_EQ(tum.timestamps, stamps);
  EXPECT_LT((tum.poses[2] - icp[2]).norm(), 1e-12);
}

TEST(ScanFormats, ThreeDtkNamesAndExtensions)
{
  EXPECT_EQ(scanFormatFromName("uos"), "3d");
  EXPECT_EQ(scanFormatFromName("3D"), "3d");
  EXPECT_EQ(scanFormatFromName("velodyne"), "bin");
  EXPECT_EQ(scanFormatFromName("KITTI"), "bin");
  EXPECT_EQ(scanFormatFromName("pcl"), "pcd");
  EXPECT_EQ(scanFormatFromName("PLY"), "ply");
  EXPECT_EQ(scanFormatFromName("xyz"), "xyz");
  EXPECT_EQ(scanFormatFromName("las"), "");
  EXPECT_EQ(scanFormatFromName(""), "");
}

namespace {

/** The inode of what descriptor `fd` writes to. */
ino_t
inodeOf(int fd)
{
  struct stat s {};
  return ::fstat(fd, &s) == 0 ? s.st_ino : 0;
}

} // namespace

// What PCL prints on stderr comes back condensed by kind, each line once, and stderr is
// the terminal's again afterwards.
TEST(StderrCapture, CondensesRepeatsAndRestoresStderr)
{
  const ino_t before = inodeOf(2);
  {
    StderrCapture capture;
    ASSERT_TRUE(capture.active());
    EXPECT_NE(inodeOf(2), before);
    EXPECT_NE(capture.terminalDescriptor(), 2);
    EXPECT_EQ(inodeOf(capture.terminalDescriptor()), before);
    std::fprintf(stderr, "Link 3 -> 9 dropped\n\nother 1\nLink 40 -> 120 dropped\r\n");
    std::cerr << "Link 5 -> 6 dropped\nLink x dropped\n";
    EXPECT_EQ(capture.take(),
              (std::vector<std::string>{
                  "Link 3 -> 9 dropped  (and 2 more like it)", "other 1", "Link x dropped"}));
    EXPECT_TRUE(capture.take().empty()); // each line once
    const std::string write_through = "written 7 after a take\n";
    ASSERT_EQ(::write(2, write_through.data(), write_through.size()),
              static_cast<ssize_t>(write_through.size()));
    EXPECT_EQ(capture.take(), (std::vector<std::string>{"written 7 after a take"}));
  }
  EXPECT_EQ(inodeOf(2), before);
}
