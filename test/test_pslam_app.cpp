/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The pcl_pslam app shell: 3DTK command lines, the scan directory as the app opens it,
 * output formats read back, every writer on a full disk, and .frames on real 3DTK data
 * against slam6D's own output.
 */
#include "input.h"
#include "options.h"
#include "outputs.h"
#include "test_data.h"

#include <pcl_parallel/evaluation/pose_error.h>
#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/io/scan_directory.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/uos.h>
#include <pcl_parallel/render/map_picture.h>
#include <pcl_parallel/sim/presets.h>
#include <pcl_parallel/sim/scan_set_writer.h>
#include <pcl_parallel/slam/preprocess.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <iomanip>
#include <iterator>
#include <map>
#include <random>
#include <sstream>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

namespace fs = std::filesystem;

namespace {

constexpr double kDeg = M_PI / 180.0;

pcl_pslam::Options
parse(std::vector<const char*> args)
{
  args.insert(args.begin(), "pcl_pslam");
  return pcl_pslam::parseCommandLine(static_cast<int>(args.size()), args.data());
}

fs::path
scratch(const std::string& name)
{
  const fs::path p =
      fs::temp_directory_path() / ("pcl_pslam_app_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

Eigen::Matrix4d
somePose(double a, double b, double c, const Eigen::Vector3d& t)
{
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(b, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(c, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  m.topRightCorner<3, 1>() = t;
  return m;
}

/** The map pass as the app runs it: slam::assembleMap with the options' parameters. */
pcl_pslam::Cloud::Ptr
mapOf(const pcl_pslam::Options& o,
      const pcl_pslam::Input& in,
      const pcl_pslam::Poses& poses,
      double voxel_size)
{
  return pcl_parallel::slam::assembleMap(
      in, poses, pcl_pslam::toParameters(o, in.scale), voxel_size);
}

} // namespace

// A 3DTK user's slam6D command line means the same here, in the files' units (cm).
TEST(PslamOptions, SlamSixDCommandLineInFileUnits)
{
  const auto o = parse({"run", "-s", "0",   "-e", "65", "-r",       "10",  "-i", "100", "-d",
                        "75",  "-D", "250", "-I", "50", "--cldist", "750", "-f", "uos", "dat"});
  EXPECT_EQ(o.command, "run");
  EXPECT_EQ(o.dir, "dat");
  EXPECT_EQ(o.format, "3d");
  EXPECT_EQ(o.first, 0);
  EXPECT_EQ(o.last, 65);
  const auto p = pcl_pslam::toParameters(o, 0.01); // uos: centimetres
  EXPECT_DOUBLE_EQ(p.reduction.voxel_size, 0.1);
  EXPECT_DOUBLE_EQ(p.matcher.max_correspondence_distance, 0.75);
  EXPECT_DOUBLE_EQ(p.loops.lum_distance, 2.5);
  EXPECT_DOUBLE_EQ(p.loops.distance, 7.5);
  EXPECT_EQ(p.matcher.max_iterations, 100);
  EXPECT_EQ(p.loops.lum_iterations, 50);
  // Unset lengths stay automatic whatever the files' units.
  EXPECT_DOUBLE_EQ(p.loops.lum_final_distance, 0.0);
  EXPECT_DOUBLE_EQ(p.matcher.final_correspondence_distance, 0.0);
  EXPECT_DOUBLE_EQ(pcl_pslam::toParameters(parse({"run", "--icp-final", "20", "d"}), 0.01)
                       .matcher.final_correspondence_distance,
                   0.2);
  // 3DTK's long names and the app's own are the same options.
  const auto l = parse({"run",
                        "--max=500",
                        "--min",
                        "50",
                        "--loopsize",
                        "7",
                        "--iterSLAM",
                        "3",
                        "--voxel",
                        "20",
                        "--icp-distance",
                        "30",
                        "d"});
  EXPECT_EQ(l.max_range, 500.0);
  EXPECT_EQ(l.min_range, 50.0);
  EXPECT_EQ(l.loop_size, 7);
  EXPECT_EQ(l.lum_iterations, 3);
  EXPECT_DOUBLE_EQ(pcl_pslam::toParameters(l, 1.0).reduction.voxel_size, 20.0);
  EXPECT_DOUBLE_EQ(pcl_pslam::toParameters(l, 1.0).matcher.max_correspondence_distance, 30.0);
  const auto m = parse({"run", "-m", "3000", "-M", "50", "d"}); // -m max, -M min as slam6D
  EXPECT_EQ(m.max_range, 3000.0);
  EXPECT_EQ(m.min_range, 50.0);
  // ... and reach the pipeline in metres (it sizes its local map by the range).
  EXPECT_DOUBLE_EQ(pcl_pslam::toParameters(m, 0.01).reduction.max_range, 30.0);
  EXPECT_DOUBLE_EQ(pcl_pslam::toParameters(m, 0.01).reduction.min_range, 0.5);
  EXPECT_TRUE(std::isinf(pcl_pslam::toParameters(o, 0.01).reduction.max_range));
  // slam6D's -L: 0 no loop closing before pLUM, 1-4 ELCH; ours on by default.
  EXPECT_TRUE(pcl_pslam::toParameters(o, 1.0).loops.distribute_error);
  EXPECT_FALSE(
      pcl_pslam::toParameters(parse({"run", "-L", "0", "d"}), 1.0).loops.distribute_error);
  EXPECT_TRUE(pcl_pslam::toParameters(parse({"run", "--loop6DAlgo", "4", "d"}), 1.0)
                  .loops.distribute_error);
  EXPECT_TRUE(pcl_pslam::toParameters(o, 1.0).loops.sequence_constraints);
  const auto no_constraints = parse({"run", "--no-sequence-constraints", "d"});
  EXPECT_FALSE(pcl_pslam::toParameters(no_constraints, 1.0).loops.sequence_constraints);
  // Segments: off unless asked for (one front end, loops fed back online); over ranks
  // whenever there are several.
  using pcl_parallel::slam::MappingBackend;
  EXPECT_EQ(pcl_pslam::toMappingOptions(o, 1).backend, MappingBackend::kOnline);
  EXPECT_EQ(pcl_pslam::toMappingOptions(o, 1).segment_size, 0u);
  EXPECT_EQ(pcl_pslam::toMappingOptions(o, 2).backend, MappingBackend::kRanks);
  const auto segmented = parse({"run", "--segment-size", "40", "--segment-overlap", "3", "d"});
  EXPECT_EQ(pcl_pslam::toMappingOptions(segmented, 1).backend, MappingBackend::kSegments);
  EXPECT_EQ(pcl_pslam::toMappingOptions(segmented, 1).segment_size, 40u);
  EXPECT_EQ(pcl_pslam::toMappingOptions(segmented, 1).segment_overlap, 3u);
  EXPECT_EQ(pcl_pslam::toMappingOptions(segmented, 3).backend, MappingBackend::kRanks);
}

TEST(PslamOptions, BadUsageIsOneLine)
{
  auto message = [](std::vector<const char*> args) -> std::string {
    try {
      parse(args);
    }
    catch (const pcl_pslam::UsageError& e) {
      return e.what();
    }
    return "";
  };
  EXPECT_NE(message({"run", "--frobnicate", "d"}).find("--frobnicate"), std::string::npos);
  EXPECT_NE(message({"run", "-f", "foo", "d"}).find("unknown scan format 'foo'"),
            std::string::npos);
  EXPECT_NE(message({"run", "-d", "abc", "d"}).find("dist"), std::string::npos);
  EXPECT_NE(message({"run", "-s", "5", "-e", "2", "d"}).find("-e"), std::string::npos);
  EXPECT_NE(message({"run"}).find("no scan directory"), std::string::npos);
  EXPECT_NE(message({"run", "a", "b"}).find("one directory"), std::string::npos);
  EXPECT_NE(message({"frob"}).find("unknown command 'frob'"), std::string::npos);
  EXPECT_NE(message({"run", "-L", "7", "d"}).find("-L/--loop6DAlgo"), std::string::npos);
  // Every numeric option has a stated range (an internal error deep in the run before).
  EXPECT_NE(message({"run", "-r", "1e-9", "d"}).find("--reduce takes 1e-06 to 1e+09 or 0"),
            std::string::npos);
  for (const char* scale : {"1e-30", "1e30"})
    EXPECT_NE(message({"run", "--scale", scale, "d"}).find("--scale takes 1e-06 to 1e+06"),
              std::string::npos);
  for (const char* threads : {"1025", "10000"})
    EXPECT_NE(
        message({"run", "-t", threads, "d"}).find("-t/--threads takes 0 to 1024"),
        std::string::npos);
  EXPECT_NE(message({"run", "--segment-overlap", "0", "d"}).find("--segment-overlap"),
            std::string::npos);
  EXPECT_NE(message({"run", "--segment-overlap", "-1", "d"}).find("--segment-overlap"),
            std::string::npos);
  EXPECT_NE(
      message({"run", "--sweep-period", "0.1", "d"}).find("--sweep-period needs --deskew"),
      std::string::npos);
  EXPECT_NE(message({"run", "--sweep-ccw", "d"}).find("--sweep-ccw needs --deskew"),
            std::string::npos);
  EXPECT_NE(message({"run", "--deskew", "--sweep-period", "-0.1", "d"}).find("--sweep-period"),
            std::string::npos);
  EXPECT_NE(message({"demo", "--reduc", "1"}).find("--reduc"),
            std::string::npos); // no guessing
  for (const std::string& m :
       {message({"run", "--frobnicate", "d"}), message({"run", "-f", "foo", "d"})})
    EXPECT_EQ(m.find('\n'), std::string::npos);
}

// --help explains every option with a default or a unit.
TEST(PslamOptions, HelpNamesEveryOption)
{
  std::string h; // Boost wraps the text: white space collapsed to one blank
  for (char c : pcl_pslam::helpText("run"))
    if (!std::isspace(static_cast<unsigned char>(c)) || (!h.empty() && h.back() != ' '))
      h += std::isspace(static_cast<unsigned char>(c)) ? ' ' : c;
  for (const char* name :
       {"--format", "--start",   "--end",      "--max",      "--min",    "--reduce",
        "--iter",   "--dist",    "--iterSLAM", "--distSLAM", "--cldist", "--loopsize",
        "--epsICP", "--epsSLAM", "--metascan", "--poses",    "--out",    "--threads",
        "--quiet",  "--ply",     "--style"})
    EXPECT_NE(h.find(name), std::string::npos) << name;
  for (const char* name : {"--loop6DAlgo",
                           "--no-sequence-constraints",
                           "--segment-size",
                           "--segment-overlap",
                           "--deskew",
                           "--sweep-period",
                           "--sweep-ccw"})
    EXPECT_NE(h.find(name), std::string::npos) << name;
  EXPECT_NE(h.find("[default 5]"), std::string::npos); // -l (the path rule does the rest)
  EXPECT_NE(h.find("[default: auto, 10 voxels]"), std::string::npos);
  // Every numeric option's range, as the checks have it: one sample each way.
  for (const char* range : {"-m/--max 1e-06 to 1e+09;",
                            "-r/--reduce 1e-06 to 1e+09 or 0;",
                            "--scale 1e-06 to 1e+06;",
                            "--sweep-period 0.0001 to 3600;",
                            "-i/--iter 1 or more;",
                            "-L/--loop6DAlgo 0 to 4;",
                            "-t/--threads 0 to 1024;",
                            "--segment-size 0 to 1e+08;"})
    EXPECT_NE(h.find(range), std::string::npos) << range;
  EXPECT_THROW(parse({"run", ".", "--sweep-period", "3601", "--deskew"}),
               pcl_pslam::UsageError);
  EXPECT_THROW(parse({"run", ".", "--scale", "1e7"}), pcl_pslam::UsageError);
}

// .frames lines read back by the library's 3DTK reader give the pose (in 3DTK units).
TEST(PslamOutputs, FramesRoundTrip)
{
  const fs::path dir = scratch("frames");
  const Eigen::Matrix4d initial = somePose(0.1, 0.0, 0.0, {1, 2, 3});
  const Eigen::Matrix4d icp = somePose(0.2, -0.05, 0.03, {1.5, -0.25, 3.125});
  const Eigen::Matrix4d final_pose = somePose(0.3, 0.1, -0.2, {-7.3, 0.04, 12.5});
  const std::string path = (dir / "scan001.frames").string();
  pcl_parallel::io::writeScanFrames(path, initial, icp, final_pose, false, 0.01);
  const Eigen::Matrix4d back = pcl_parallel::io::loadFramesFinalPose(path);
  Eigen::Matrix4d expected = final_pose;
  expected.topRightCorner<3, 1>() /= 0.01; // metres -> 3DTK's centimetres
  EXPECT_LT((back - expected).cwiseAbs().maxCoeff(), 1e-9);
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> lines;
  while (std::getline(in, line))
    lines.push_back(line);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_EQ(lines[0].back(), '0'); // INVALID (initial), ICP, LUM
  EXPECT_EQ(lines[1].back(), '1');
  EXPECT_EQ(lines[2].back(), '3');
  fs::remove_all(dir);
}

// TUM lines: time, position, unit quaternion (x y z w) of the same rotation.
TEST(PslamOutputs, TumRoundTrip)
{
  const fs::path dir = scratch("tum");
  const pcl_pslam::Poses poses = {somePose(0, 0, 0, {0, 0, 0}),
                                  somePose(2.9, 0.4, -1.2, {10, -20, 0.5}),
                                  somePose(-3.1, 1.5, 3.1, {1e3, 2e3, -3})};
  const std::vector<double> stamps = {1565943983.5248752, 1565943989.0262754, 1565943991.5};
  const std::string path = (dir / "poses_tum.txt").string();
  pcl_parallel::io::writeTumTrajectory(path, poses, stamps);
  std::ifstream in(path);
  std::string header;
  ASSERT_TRUE(std::getline(in, header)); // "# timestamp tx ty tz qx qy qz qw"
  EXPECT_EQ(header.rfind("# timestamp", 0), 0u);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    double t, x, y, z, qx, qy, qz, qw;
    ASSERT_TRUE(in >> t >> x >> y >> z >> qx >> qy >> qz >> qw);
    EXPECT_NEAR(t, stamps[i], 1e-6); // Unix times keep their microseconds
    EXPECT_LT((Eigen::Vector3d(x, y, z) - poses[i].topRightCorner<3, 1>()).norm(), 1e-8);
    const Eigen::Matrix3d r = Eigen::Quaterniond(qw, qx, qy, qz).toRotationMatrix();
    EXPECT_LT((r - poses[i].topLeftCorner<3, 3>()).cwiseAbs().maxCoeff(), 1e-8);
  }
  fs::remove_all(dir);
}

// With --deskew the map shows each scan deskewed by the motion at its final pose, as the
// front end matched it. Scans of a screw motion (a constant twist, which deskewing models
// exactly) with per-point times, written as Ouster-like .pcd files, consecutive sweeps and
// keyframes 0.5 s apart (--sweep-period): mapped at the true poses, every point lands on
// the world point it measured. As read, the map is up to half a sweep's motion off.
TEST(PslamOutputs, MapShowsScansDeskewedAtTheirPoses)
{
  namespace sim = pcl_parallel::sim;
  // 9 m/s turning 25 deg/s and climbing, per 0.1 s sweep.
  const Eigen::Matrix4d sweep =
      somePose(2.5 * kDeg, 0.4 * kDeg, -0.3 * kDeg, {0.9, 0.05, 0.02});
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(-30.0, 30.0), h(-2.0, 4.0);
  std::vector<Eigen::Vector3d> world;
  for (int i = 0; i < 25000; ++i) // above the parallel thresholds of deskew and the map
    world.emplace_back(u(rng), u(rng), h(rng));
  for (const int stride : {1, 5}) {
    SCOPED_TRACE(stride);
    sim::SimulatedScanSet set;
    set.scanner.sweep_period = 0.1;
    for (int k = 0; k < 5; ++k) {
      const Eigen::Matrix4d mid = pcl_parallel::slam::interpolateMotion(sweep, stride * k);
      set.truth.push_back(mid);
      set.timestamps.push_back(0.1 * stride * k);
      auto scan = std::make_shared<pcl_pslam::Cloud>();
      std::vector<float> times;
      for (std::size_t i = 0; i < world.size(); ++i) {
        const float t = static_cast<float>(i % 11) / 10.0f; // 0 and 1 among them
        const Eigen::Matrix4d at = mid * pcl_parallel::slam::interpolateMotion(sweep, t - 0.5);
        const Eigen::Vector3f p =
            (at.inverse() * world[i].homogeneous()).head<3>().cast<float>();
        scan->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
        times.push_back(t);
      }
      set.scans.push_back(scan);
      set.point_times.push_back(times);
    }
    set.odometry = set.truth;
    const fs::path dir = scratch("deskewed_map");
    sim::writeScanSet(set, dir.string(), sim::ScanSetFormat::Pcd);
    auto worst = [&](bool deskew) {
      std::vector<const char*> args = {"run", dir.c_str()};
      if (deskew)
        args.push_back("--deskew");
      if (deskew && stride > 1)
        args.insert(args.end(), {"--sweep-period", "0.1"});
      const pcl_pslam::Options o = parse(args);
      const pcl_pslam::Input in = pcl_pslam::openDirectory(o);
      const auto map = mapOf(o, in, set.truth, 0.0); // every point, in order
      EXPECT_EQ(map->size(), 5 * world.size());
      double error = 0.0;
      for (std::size_t j = 0; j < map->size(); ++j)
        error = std::max(
            error,
            ((*map)[j].getVector3fMap().cast<double>() - world[j % world.size()]).norm());
      return error;
    };
    EXPECT_LT(worst(true), 1e-4);
    EXPECT_GT(worst(false), 0.3);
    // The voxel map of the deskewed scans, the same for any thread count.
    std::vector<pcl_pslam::Cloud::Ptr> maps;
    for (const char* threads : {"1", "3"}) {
      const pcl_pslam::Options o = parse({"run", dir.c_str(), "--deskew", "-t", threads});
      maps.push_back(mapOf(o, pcl_pslam::openDirectory(o), set.truth, 0.5));
    }
    ASSERT_EQ(maps[0]->size(), maps[1]->size());
    for (std::size_t j = 0; j < maps[0]->size(); ++j)
      ASSERT_TRUE((*maps[0])[j].getVector3fMap() == (*maps[1])[j].getVector3fMap()) << j;
    // Scans broken after the first pass (2 and 3, prepared in one batch with 1): the map
    // pass, which prepares several at once, names the first, as a scan-by-scan pass would.
    const pcl_pslam::Options o = parse({"run", dir.c_str(), "--deskew", "-t", "3"});
    const pcl_pslam::Input in = pcl_pslam::openDirectory(o);
    for (const char* name : {"000002.pcd", "000003.pcd"})
      std::ofstream(dir / name) << "not a point cloud\n";
    try {
      mapOf(o, in, set.truth, 0.5);
      ADD_FAILURE() << "no error";
    }
    catch (const pcl_pslam::DataError& e) {
      EXPECT_NE(std::string(e.what()).find("000002.pcd"), std::string::npos) << e.what();
    }
    fs::remove_all(dir);
  }
}

namespace {

/** Files limited to `bytes` in this process (writes beyond fail with EFBIG, as on a full
 *  disk; SIGXFSZ ignored) while it lives. */
class FileSizeLimit {
public:
  explicit FileSizeLimit(rlim_t bytes)
  {
    old_handler_ = std::signal(SIGXFSZ, SIG_IGN);
    ::getrlimit(RLIMIT_FSIZE, &old_);
    rlimit limit = old_;
    limit.rlim_cur = bytes;
    ::setrlimit(RLIMIT_FSIZE, &limit);
  }
  ~FileSizeLimit()
  {
    ::setrlimit(RLIMIT_FSIZE, &old_); // a soft limit may be raised again up to the hard one
    std::signal(SIGXFSZ, old_handler_);
  }

private:
  rlimit old_;
  void (*old_handler_)(int);
};

} // namespace

// Every writer of `run` on a full disk: an error naming the file (not its temporary), no
// file under the name or a temporary left, an old file of that name kept intact.
TEST(PslamOutputs, FullDiskIsAnErrorNamingTheFileAndLeavesNoFile)
{
  const fs::path dir = scratch("full");
  pcl_pslam::Cloud map;
  for (int i = 0; i < 2000; ++i)
    map.emplace_back(0.01f * i, std::sin(0.01f * i), 1.0f);
  pcl_pslam::Poses poses;
  for (int i = 0; i < 50; ++i)
    poses.push_back(somePose(0.1 * i, 0.01 * i, -0.02 * i, Eigen::Vector3d(i, 0.5 * i, 0)));
  const std::vector<double> stamps(poses.size(), 1.5);
  pcl_parallel::render::PictureOptions po;
  po.caption = {"full disk"};
  const std::pair<const char*, std::function<void(const std::string&)>> writers[] = {
      {"scan000.frames",
       [&](const std::string& p) {
         pcl_parallel::io::writeScanFrames(p, poses[1], poses[2], poses[3], false, 0.01);
       }},
      {"poses.txt", [&](const std::string& p) { pcl_parallel::io::writeKittiPoses(p, poses); }},
      {"poses_tum.txt",
       [&](const std::string& p) { pcl_parallel::io::writeTumTrajectory(p, poses, stamps); }},
      {"map.pcd", [&](const std::string& p) { pcl_parallel::io::writePcdScan(p, map); }},
      {"map.ply", [&](const std::string& p) { pcl_parallel::io::writePlyScan(p, map); }},
      {"map.png", [&](const std::string& p) {
         pcl_parallel::render::writeMapPicture(p, map, poses, po);
       }}};
  for (const auto& [name, write] : writers) {
    const std::string path = (dir / name).string();
    for (const bool old_file : {false, true}) {
      if (old_file)
        std::ofstream(path) << "old\n";
      std::string message = "no exception";
      {
        const FileSizeLimit limit(100); // each of these files is larger
        try {
          write(path);
        }
        catch (const std::runtime_error& e) {
          message = e.what();
        }
      }
      EXPECT_NE(message.find(path + ": "), std::string::npos) << name << ": " << message;
      EXPECT_EQ(message.find(".tmp"), std::string::npos) << name << ": " << message;
      std::vector<std::string> left;
      for (const auto& e : fs::directory_iterator(dir))
        left.push_back(e.path().filename().string());
      if (old_file) {
        std::ifstream in(path);
        std::string content;
        std::getline(in, content);
        EXPECT_EQ(content, "old") << name;
        EXPECT_EQ(left, std::vector<std::string>{name});
      }
      else
        EXPECT_TRUE(left.empty()) << name << ": " << left.front();
    }
    fs::remove(path);
    write(path); // and without the limit, the file is written
    EXPECT_GT(fs::file_size(path), 100u) << name;
    fs::remove(path);
  }
  fs::remove_all(dir);
}

// An input directory or scan file that cannot be read (permissions: not as root, which
// reads anything) is an error naming it.
// Scans are matched in the order they were taken: numbered names by their numbers (an
// export's cloud_2 before cloud_10), other names, timestamps among them, by name.
TEST(PslamInput, NumberedNamesAreReadInTheirNumbersOrder)
{
  const auto order = [](const std::string& name, const std::vector<std::string>& stems) {
    const fs::path dir = scratch(name);
    for (const auto& stem : stems)
      std::ofstream(dir / (stem + ".xyz")) << "0 0 1\n1 0 1\n0 1 1\n";
    pcl_pslam::Options o;
    o.command = "run";
    o.dir = dir.string();
    std::vector<std::string> read;
    for (const auto& f : pcl_pslam::openDirectory(o).files)
      read.push_back(fs::path(f).stem().string());
    fs::remove_all(dir);
    return read;
  };
  using Names = std::vector<std::string>;
  EXPECT_EQ(order("order_unpadded", {"cloud_10", "cloud_2", "cloud_1", "cloud_11"}),
            (Names{"cloud_1", "cloud_2", "cloud_10", "cloud_11"}));
  EXPECT_EQ(order("order_digits", {"10", "9", "100"}), (Names{"9", "10", "100"}));
  EXPECT_EQ(order("order_padded", {"scan010", "scan002", "scan100"}),
            (Names{"scan002", "scan010", "scan100"}));
  // Decimal seconds: the number after the point is a fraction, the names decide.
  EXPECT_EQ(order("order_stamps", {"1317384506.5", "1317384506.25", "1317384507.05"}),
            (Names{"1317384506.25", "1317384506.5", "1317384507.05"}));
  // Two prefixes, or one number twice (scan1, scan01): by name.
  EXPECT_EQ(order("order_mixed", {"b2", "a10", "a3"}), (Names{"a10", "a3", "b2"}));
  EXPECT_EQ(order("order_twice", {"scan1", "scan01", "scan2"}),
            (Names{"scan01", "scan1", "scan2"}));
}

// --poses reads KITTI and TUM alike (a TUM file: the same poses, and its stamps become the
// scans' unless times.txt gives them).
TEST(PslamInput, PosesInKittiOrTumFormat)
{
  const fs::path dir = scratch("tum_poses");
  for (int s = 0; s < 3; ++s)
    std::ofstream(dir / ("scan" + std::to_string(s) + ".xyz")) << "0 0 1\n1 0 1\n0 1 1\n";
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()));
  std::ofstream kitti(dir.parent_path() / "tum_poses.kitti"),
      tum(dir.parent_path() / "tum_poses.tum");
  tum << "# timestamp tx ty tz qx qy qz qw\n" << std::setprecision(17);
  kitti << std::setprecision(17);
  for (int s = 0; s < 3; ++s) {
    const Eigen::Matrix3d r = q.toRotationMatrix();
    for (int row = 0; row < 3; ++row)
      kitti << r(row, 0) << ' ' << r(row, 1) << ' ' << r(row, 2) << ' ' << s + row << ' ';
    kitti << '\n';
    tum << 100.5 + 0.1 * s << ' ' << s << ' ' << s + 1 << ' ' << s + 2 << ' ' << q.x() << ' '
        << q.y() << ' ' << q.z() << ' ' << q.w() << '\n';
  }
  kitti.close();
  tum.close();
  pcl_pslam::Options o;
  o.command = "run";
  o.dir = dir.string();
  o.poses_file = (dir.parent_path() / "tum_poses.kitti").string();
  const pcl_pslam::Input from_kitti = pcl_pslam::openDirectory(o);
  o.poses_file = (dir.parent_path() / "tum_poses.tum").string();
  const pcl_pslam::Input from_tum = pcl_pslam::openDirectory(o);
  ASSERT_EQ(from_tum.initial.size(), 3u);
  for (std::size_t s = 0; s < 3; ++s)
    EXPECT_TRUE(from_tum.initial[s].isApprox(from_kitti.initial[s], 1e-12)) << "scan " << s;
  EXPECT_FALSE(from_kitti.has_stamps);
  EXPECT_TRUE(from_tum.has_stamps);
  EXPECT_EQ(from_tum.stamps, (std::vector<double>{100.5, 100.6, 100.7}));
  std::ofstream(dir / "times.txt") << "7\n8\n9\n";
  EXPECT_EQ(pcl_pslam::openDirectory(o).stamps, (std::vector<double>{7, 8, 9}));
  fs::remove_all(dir);
  fs::remove(dir.parent_path() / "tum_poses.kitti");
  fs::remove(dir.parent_path() / "tum_poses.tum");
}

TEST(PslamInput, UnreadableDirectoryAndScanFileAreErrorsNamingThem)
{
  if (::geteuid() == 0)
    GTEST_SKIP() << "running as root: permission bits do not stop reads";
  const fs::path dir = scratch("unreadable");
  for (int s = 0; s < 3; ++s) {
    std::ofstream out(dir / ("scan" + std::to_string(s) + ".xyz"));
    for (int i = 0; i < 10; ++i)
      for (int j = 0; j < 10; ++j)
        out << i << ' ' << j << " 0\n" << i << " 0 " << j << "\n0 " << i << ' ' << j << '\n';
  }
  pcl_pslam::Options o;
  o.command = "run";
  o.dir = dir.string();
  auto errorOf = [&] {
    try {
      pcl_parallel::io::readAllScans(pcl_pslam::openDirectory(o));
    }
    catch (const pcl_pslam::DataError& e) {
      return std::string(e.what());
    }
    return std::string("no DataError");
  };
  fs::permissions(dir / "scan1.xyz", fs::perms::none);
  EXPECT_NE(errorOf().find((dir / "scan1.xyz").string() + ": cannot open"), std::string::npos)
      << errorOf();
  fs::permissions(dir, fs::perms::none);
  EXPECT_NE(errorOf().find(dir.string() + ": cannot list the directory"), std::string::npos)
      << errorOf();
  fs::permissions(dir, fs::perms::owner_all);
  fs::remove_all(dir);
}

namespace {

/** Distance (cm) and angle (deg) of the last pose in our .frames file `ours` from slam6D's
 *  2009 one of the same name; printed. */
std::pair<double, double>
fromSlamSixD(const fs::path& ours_file, const std::string& data)
{
  const std::string name = ours_file.filename().string();
  const Eigen::Matrix4d ours = pcl_parallel::io::loadFramesFinalPose(ours_file.string());
  const Eigen::Matrix4d ref =
      pcl_parallel::io::loadFramesFinalPose(data + "/reference_frames_2009/" + name);
  const double dt = (ours.topRightCorner<3, 1>() - ref.topRightCorner<3, 1>()).norm();
  const Eigen::Matrix3d dr = ours.topLeftCorner<3, 3>().transpose() * ref.topLeftCorner<3, 3>();
  const double angle = std::acos(std::clamp((dr.trace() - 1.0) / 2.0, -1.0, 1.0)) / kDeg;
  std::printf("%s: %.2f cm, %.3f deg from slam6D's final pose\n", name.c_str(), dt, angle);
  return {dt, angle};
}

// Real 3DTK data through the app's input, pipeline and .frames writer, against slam6D's
// own .frames (reference_frames_2009, slam6D parameters unknown: a sanity reference).
// Returns per scan the distance (cm) and angle (deg) of our final pose from slam6D's.
std::vector<std::pair<double, double>>
framesAgainstSlamSixD(std::vector<const char*> args)
{
  const std::string data = std::string(PCL_PARALLEL_DATA_DIR) + "/3dtk_dat";
  const fs::path out = scratch("3dtk");
  args.insert(args.begin(), "run");
  args.push_back(data.c_str());
  const auto o = parse(args);
  const pcl_pslam::Input in = pcl_pslam::openDirectory(o);
  EXPECT_EQ(in.size(), 3u);
  EXPECT_TRUE(in.frames_3dtk);
  const pcl_parallel::slam::Parameters p = pcl_pslam::toParameters(o, in.scale);
  const pcl_pslam::Result r = pcl_parallel::slam::mapScans(
      pcl_parallel::io::readAllScans(in), in.odometry ? in.initial : pcl_pslam::Poses(), p);
  std::vector<std::pair<double, double>> errors;
  for (std::size_t i = 0; i < in.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "scan%03zu.frames", i);
    pcl_parallel::io::writeScanFrames(
        (out / name).string(), in.initial[i], r.icp[i], r.final[i], i == 0, in.scale);
    errors.push_back(fromSlamSixD(out / name, data));
  }
  fs::remove_all(out);
  return errors;
}

const std::vector<const char*> kSlamSixDLine = {
    "-s",  "0",  "-e", "65",       "-r",  "10", "-i",  "100", "-d",   "75", "-D",
    "250", "-I", "50", "--cldist", "750", "-f", "uos", "-m",  "3000", "-M", "50"};

} // namespace

// A 3DTK user's command line with slam6D's matching (each scan against the previous one:
// slam6D does that unless --metascan; this app's default is a local map): scan001 1.37 cm
// 0.07 deg, scan002 0.93 cm 0.50 deg. The bounds catch the writer's conventions (cm vs m
// is a factor 100, a transposed rotation doubles the angle, a missing inversion moves
// scan002 by metres), not the pipeline's last centimetres: those are the target below.
TEST(PslamApp, ThreeDtkFramesNearSlamSixD)
{
  if (!fs::exists(std::string(PCL_PARALLEL_DATA_DIR) + "/3dtk_dat/scan000.3d"))
    GTEST_SKIP() << "no 3DTK data in " << PCL_PARALLEL_DATA_DIR;
  auto args = kSlamSixDLine;
  args.push_back("--scan-to-scan");
  for (const auto& [dt, angle] : framesAgainstSlamSixD(args)) {
    EXPECT_LT(dt, 16.0);
    EXPECT_LT(angle, 1.0);
  }
}

// Issue 10's target: the app itself (exit status, then its .frames), run with a 3DTK
// user's command line for this data (slam6D's options in cm, the range limits of the
// data's config.ini) and the app's default local map, within 2 cm / 0.5 deg of slam6D's
// own .frames on every scan. Measured: scan001 1.37 cm 0.07 deg, scan002 1.44 cm
// 0.49 deg (1.77 cm 0.28 deg and 1.18 cm 0.36 deg before the front end's coarse-to-fine
// refinement, which brought scan001 to slam6D's pitch and turned scan002 away). The margin is
// thin by nature: scans 0 and 1 disagree by ~6 cm in height (floor vs. ceiling), so pitch and
// height of scan001 move with the matcher's weighting (docs/design.md, "Real data"); a local
// map cropped inside the range (5 x the median range before) put scan001 2.9 cm / 0.63 deg
// away.
TEST(PslamApp, ThreeDtkFramesWithinTwoCentimetres)
{
  const std::string data = std::string(PCL_PARALLEL_DATA_DIR) + "/3dtk_dat";
  if (!fs::exists(data + "/scan000.3d"))
    GTEST_SKIP() << "no 3DTK data in " << PCL_PARALLEL_DATA_DIR;
  const fs::path dir = scratch("3dtk_app"), out = dir / "out"; // the log beside --out
  std::string command = std::string(PCL_PSLAM_EXE) + " run";
  for (const char* a : kSlamSixDLine)
    command += std::string(" ") + a;
  command +=
      " -q --out " + out.string() + " " + data + " > " + (dir / "log.txt").string() + " 2>&1";
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status)) << command;
  ASSERT_EQ(WEXITSTATUS(status), 0) << command;
  for (int i = 0; i < 3; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "scan%03d.frames", i);
    const auto [dt, angle] = fromSlamSixD(out / name, data);
    EXPECT_LT(dt, 2.0) << name;
    EXPECT_LT(angle, 0.5) << name;
  }
  fs::remove_all(dir);
}

// A scan file or --out whose name is not UTF-8 (a Latin-1 name on Linux) is mapped and
// reported: report.json, which must be UTF-8, carries U+FFFD for the byte, instead of the
// run failing in the JSON writer after all the work with report.json missing.
TEST(PslamApp, NamesThatAreNotUtf8AreReportedNotFatal)
{
  const fs::path dir = scratch("latin1_\xe9");
  std::ostringstream points; // three walls of a corner, 10 x 10 points each
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j)
      points << i + 0.5 << ' ' << j << " 0\n"
             << i << " 0.5 " << j << '\n'
             << "0.5 " << i << ' ' << j << '\n';
  for (const char* name : {"scan_\xe9_0.xyz", "scan_\xe9_1.xyz"})
    std::ofstream(dir / name) << points.str();
  const fs::path out = dir / "out_\xe9";
  const std::string command = std::string(PCL_PSLAM_EXE) + " run -q --no-picture --out '" +
                              out.string() + "' '" + dir.string() + "' > /dev/null 2>&1";
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status)) << command;
  EXPECT_EQ(WEXITSTATUS(status), 0) << command;
  std::ifstream report(out / "report.json");
  ASSERT_TRUE(report.good());
  const std::string text((std::istreambuf_iterator<char>(report)), {});
  EXPECT_NE(text.find("scan_\xef\xbf\xbd_0.xyz"), std::string::npos); // U+FFFD in UTF-8
  fs::remove_all(dir);
}

/** Runs pcl_pslam with `args` (and `env` before it); its exit status (128 + the signal
 *  that ended it, as the shell reports it). */
int
runApp(const std::string& args, const std::string& env = "")
{
  const std::string command =
      env + " " + std::string(PCL_PSLAM_EXE) + " " + args + " > /dev/null 2>&1";
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status); // sh: 128 + sig
}

/** The files in `dir` with their bytes (report.json's timings left out: its outputs list). */
std::map<std::string, std::string>
filesOf(const fs::path& dir)
{
  std::map<std::string, std::string> files;
  for (const auto& entry : fs::directory_iterator(dir)) {
    std::ifstream in(entry.path(), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    if (entry.path().filename() == "report.json")
      bytes = bytes.substr(bytes.find("\"outputs\""), 400);
    files[entry.path().filename().string()] = bytes;
  }
  return files;
}

/** Six scans of three walls of a corner (10 x 10 points each), shifted 0.1 m a scan. */
void
writeCornerScans(const fs::path& dir)
{
  fs::create_directories(dir);
  for (int s = 0; s < 6; ++s) {
    std::ofstream scan(dir / ("scan" + std::to_string(s) + ".xyz"));
    for (int i = 0; i < 10; ++i)
      for (int j = 0; j < 10; ++j)
        scan << i + 0.1 * s << ' ' << j << " 0\n"
             << i + 0.1 * s << " 0 " << j << '\n'
             << 0.1 * s << ' ' << i << ' ' << j << '\n';
  }
}

// A run's outputs are one unit (docs/robustness.md): a run interrupted at each of its stages
// (the test hook raises the signal at the stage's first progress update) leaves an earlier
// run's outputs byte for byte, and nothing beside them; one that ends leaves exactly its own,
// byte for byte those of the same run into a fresh directory. A killed run's temporary
// directory is removed by the next run.
TEST(PslamApp, OneRunsOutputsWhateverStageEndsIt)
{
  const fs::path dir = scratch("one_unit");
  writeCornerScans(dir / "scans");
  const fs::path out = dir / "out";
  const std::string scans = " '" + (dir / "scans").string() + "' -q --out ";
  const std::string old_run = "run" + scans + "'" + out.string() + "' --ply";
  const std::string new_run = "run" + scans + "'" + out.string() + "' --map-voxel 0.5";
  ASSERT_EQ(runApp(old_run), 0);
  const auto old_files = filesOf(out);
  ASSERT_EQ(old_files.count("map.ply"), 1u);
  ASSERT_EQ(runApp("run" + scans + "'" + (dir / "fresh").string() + "' --map-voxel 0.5"), 0);
  const auto new_files = filesOf(dir / "fresh");
  fs::remove_all(dir / "fresh");
  const auto expectOld = [&](const std::string& args, const std::string& hook, int status) {
    EXPECT_EQ(runApp(args, "PCL_PSLAM_TEST_SIGNAL_AT=" + hook), status) << hook;
    EXPECT_EQ(filesOf(out), old_files) << hook;
    EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 2)
        << hook << ": a temporary left beside --out";
  };
  for (const char* stage : {"icp", "pLUM", "write", "map", "save", "picture", "report"})
    expectOld(new_run, std::string(stage) + ":INT", 130);
  expectOld(new_run, "write:HUP", 129);
  expectOld(new_run, "map:TERM", 143);
  expectOld("demo -q --out '" + out.string() + "'", "simulate:INT", 130);
  EXPECT_EQ(runApp(new_run, "PCL_PSLAM_TEST_SIGNAL_AT=save:KILL"), 128 + SIGKILL);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 3)
      << "the killed run's temporary directory";
  EXPECT_EQ(filesOf(out), old_files);
  EXPECT_EQ(runApp(new_run), 0);
  EXPECT_EQ(filesOf(out), new_files); // map.ply and the old run's report gone
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 2);
  // A directory with a file no run wrote is refused before any work (exit 2), unchanged.
  std::ofstream(out / "notes.md") << "mine";
  EXPECT_EQ(runApp(old_run), 2);
  EXPECT_EQ(filesOf(out).size(), new_files.size() + 1);
  fs::remove_all(dir);
}

// `simulate` into a folder that holds a larger set of another format leaves the new set
// alone (before: both sets, and one ground_truth.txt for one of them).
TEST(PslamApp, SimulateReplacesTheScanSetThere)
{
  const fs::path dir = scratch("simulate_unit");
  ASSERT_EQ(runApp("simulate --preset office --format uos '" + dir.string() + "/set'"), 0);
  ASSERT_TRUE(fs::exists(dir / "set" / "scan010.3d"));
  ASSERT_EQ(runApp("simulate --preset office --format kitti '" + dir.string() + "/set'"), 0);
  const auto files = filesOf(dir / "set");
  EXPECT_EQ(files.size(), 11u + 3u); // NNNNNN.bin, odometry.txt, times.txt, ground_truth.txt
  EXPECT_EQ(files.count("scan000.3d") + files.count("scan000.pose"), 0u);
  std::ofstream(dir / "set" / "notes.md") << "mine";
  EXPECT_EQ(runApp("simulate --preset office '" + dir.string() + "/set'"), 2);
  EXPECT_EQ(filesOf(dir / "set").size(), files.size() + 1);
  fs::remove_all(dir);
}

// A rotating 2D scanner carried 1.4 m a station down corridors (hannover, seed 2), its
// first 110 stations written as `pcl_pslam simulate` writes them and read back without
// the .pose files, as `pcl_pslam run DIR --no-loops` reads them (the scans in metres in
// memory take another path through this stretch). At station 97 the speed hypothesis a
// step short ended 0.36 m ahead and fitted the previous scan better (0.047 against 0.052
// m^2), and stations 98-103 then stood still. That match put 5.0 % of its points into the
// space the previous scan saw through, the true step 1.1 %: a better fit that contradicts
// the previous scan significantly more does not replace the leader (docs/design.md,
// "Standing still"). Before: steps 97-103 off by 1.0-1.4 m; now all within 0.4 m, 1 deg.
TEST(PslamApp, StopAndGoWithoutPosesKeepsTheMatchThatContradictsLess)
{
  if (pcl_parallel::test::kSanitized)
    GTEST_SKIP() << "110 stations: too slow under the sanitizers; test_slam's stop-and-go "
                    "and office tests run the same code there";
  pcl_parallel::sim::PresetOptions preset;
  preset.seed = 2;
  preset.max_scans = 110;
  preset.num_threads = 2;
  const pcl_parallel::sim::SimulatedScanSet set =
      pcl_parallel::sim::simulatePreset("hannover", preset);
  const fs::path dir = scratch("hannover_seed2");
  pcl_parallel::sim::writeScanSet(set, dir.string(), pcl_parallel::sim::ScanSetFormat::Uos);
  for (const auto& f : fs::directory_iterator(dir))
    if (f.path().extension() == ".pose")
      fs::remove(f.path());
  const auto o = parse({"run", dir.c_str(), "--no-loops", "-t", "2"});
  const pcl_pslam::Input in = pcl_pslam::openDirectory(o);
  ASSERT_FALSE(in.odometry);
  pcl_parallel::slam::Parameters p = pcl_pslam::toParameters(o, in.scale);
  p.guess.up = Eigen::Vector3d::Unit(in.up); // as the app sets it: y for 3DTK's frame
  const pcl_pslam::Result r = pcl_parallel::slam::mapScans(
      pcl_parallel::io::readAllScans(in), in.odometry ? in.initial : pcl_pslam::Poses(), p);
  const auto truth = pcl_parallel::io::loadKittiPoses((dir / "ground_truth.txt").string());
  ASSERT_EQ(r.icp.size(), truth.size());
  for (std::size_t i = 1; i < truth.size(); ++i) {
    const Eigen::Matrix4d step = truth[i - 1].inverse() * truth[i];
    const auto e = pcl_parallel::evaluation::poseError(r.icp[i - 1].inverse() * r.icp[i], step);
    EXPECT_LT(e.distance, 0.4) << "step " << i;
    EXPECT_LT(e.angle, 1.0 * kDeg) << "step " << i;
  }
  fs::remove_all(dir);
}
