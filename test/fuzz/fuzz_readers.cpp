/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * libFuzzer harness for our file readers (issue 11): the shared part, compiled once. Each
 * fuzz_<format> executable is fuzz_main.cpp with PCL_PARALLEL_FUZZ_FORMAT="<format>"
 * (test/fuzz/CMakeLists.txt). The readers take a path, so each input is written to a
 * private file with the reader's extension first ("frames_dir": into a directory, one file
 * per NUL-separated chunk whose first line is its name; "evaluate": two files, estimate and
 * ground truth, split at the first NUL, given to `pcl_pslam evaluate`; "options": the
 * command line; "poses": the pose rule).
 * Contract under test: a reader returns or throws std::exception (our std::runtime_error,
 * std::invalid_argument, std::out_of_range); anything else (a crash, an ASan/UBSan report,
 * a hang, an allocation beyond -malloc_limit_mb, a non-finite point in the cloud) is a bug.
 */
#include "evaluate_command.h" // apps/pcl_pslam
#include "options.h"          // apps/pcl_pslam

#include <pcl_parallel/evaluation/relations.h>
#include <pcl_parallel/io/carmen.h>
#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/stanford.h>
#include <pcl_parallel/io/uos.h>

#include <pcl/console/print.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>
#include <utility>
#include <vector>

namespace pcl_parallel_fuzz {

namespace {

namespace fs = std::filesystem;

std::string format_name, extension, input_path;

void
writeFile(const fs::path& path, const char* data, std::size_t size)
{
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(data, static_cast<std::streamsize>(size));
}

/** A trajectory reader's promise: finite poses with a rotation (TUM: from a normalised
 *  quaternion) and homogeneous last row, one finite timestamp per pose or none. */
void
checkTrajectory(const pcl_parallel::io::Trajectory& t, bool rotations)
{
  if (!t.timestamps.empty() && t.timestamps.size() != t.poses.size())
    std::abort();
  for (double s : t.timestamps)
    if (!std::isfinite(s))
      std::abort();
  for (const auto& pose : t.poses) {
    if (!pose.allFinite() || pose.row(3) != Eigen::RowVector4d(0, 0, 0, 1))
      std::abort();
    const Eigen::Matrix3d r = pose.topLeftCorner<3, 3>();
    if (rotations && !(r.transpose() * r).isApprox(Eigen::Matrix3d::Identity(), 1e-9))
      std::abort();
  }
}

/** "frames_dir": each NUL-separated chunk of the input is a file of the directory; its
 *  first line is the name (characters outside [A-Za-z0-9._-] dropped), the rest the text. */
void
writeDirectory(const std::uint8_t* data, std::size_t size)
{
  std::error_code ec;
  fs::remove_all(input_path, ec);
  fs::create_directories(input_path);
  const char* p = reinterpret_cast<const char*>(data);
  const char* end = p + size;
  for (int files = 0; p < end && files < 16; ++files) {
    const char* chunk_end = std::find(p, end, '\0');
    const char* name_end = std::find(p, chunk_end, '\n');
    std::string name;
    for (const char* c = p; c < name_end && name.size() < 40; ++c)
      if (std::isalnum(static_cast<unsigned char>(*c)) || *c == '.' || *c == '_' || *c == '-')
        name += *c;
    if (!name.empty() && name != "." && name != "..") {
      const char* body = name_end == chunk_end ? chunk_end : name_end + 1;
      writeFile(fs::path(input_path) / name, body, static_cast<std::size_t>(chunk_end - body));
    }
    p = chunk_end == end ? end : chunk_end + 1;
  }
}

/** "evaluate": the app's command on two files (estimate, ground truth). It returns 0 with a
 *  table free of nan/inf, or 1 with one error line; never 2 (the arguments are good). */
void
evaluate(const std::uint8_t* data, std::size_t size)
{
  const char* p = reinterpret_cast<const char*>(data);
  const char* split = std::find(p, p + size, '\0');
  const std::string estimate = input_path + "_estimate.txt", truth = input_path + "_truth.txt";
  writeFile(estimate, p, static_cast<std::size_t>(split - p));
  const char* t = split == p + size ? split : split + 1;
  writeFile(truth, t, static_cast<std::size_t>(p + size - t));
  static const char* const kAlign[] = {"none", "se3", "sim3"};
  std::ostringstream out, err;
  const int rc = pcl_pslam::evaluateCommand(
      {estimate, truth, "--truncate", "--align", kAlign[size % 3]}, out, err);
  std::string text = out.str();
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  if (rc == 0 ? text.find("nan") != std::string::npos || text.find("inf") != std::string::npos
              : rc != 1 || err.str().empty())
    std::abort();
}

/** "options": `run`/`demo`'s command line, the input's NUL-separated tokens after "run".
 *  The parser returns or throws UsageError (exit 2); what it returns the pipeline takes:
 *  its parameters resolve (automatic lengths from a 10 m median range) to finite, positive
 *  lengths without a throw, so no option fails late, after the work began. */
void
options(const std::uint8_t* data, std::size_t size)
{
  std::vector<std::string> tokens{"pcl_pslam", size % 2 ? "demo" : "run"};
  const char* p = reinterpret_cast<const char*>(data);
  for (const char* end = p + size; p <= end && tokens.size() < 64;) {
    const char* stop = std::find(p, end, '\0');
    tokens.emplace_back(p, stop);
    p = stop + 1;
  }
  std::vector<const char*> argv;
  for (const auto& t : tokens)
    argv.push_back(t.c_str());
  pcl_pslam::Options o;
  try {
    o = pcl_pslam::parseCommandLine(static_cast<int>(argv.size()), argv.data());
  }
  catch (const pcl_pslam::UsageError&) {
    return;
  }
  if (o.help || o.command.empty())
    return;
  pcl_parallel::slam::Parameters params = pcl_pslam::toParameters(o, o.scale.value_or(1.0));
  params = pcl_parallel::slam::resolve(params, 10.0);
  const double lengths[] = {params.reduction.voxel_size,
                            params.matcher.max_correspondence_distance,
                            params.matcher.final_correspondence_distance,
                            params.loops.distance,
                            params.loops.lum_distance,
                            params.loops.lum_final_distance};
  for (const double length : lengths)
    if (!(std::isfinite(length) && length > 0.0))
      std::abort();
}

/** "poses": the pose rule (io::poseProblem) on 16 doubles of the input, and on the KITTI
 *  poses file the input is: what it accepts is finite, rigid within kRigidMotionTolerance
 *  (R^T R - I, det R > 0, last row 0 0 0 1) and within kMaxPoseTranslation. */
void
poses(const std::uint8_t* data, std::size_t size)
{
  using namespace pcl_parallel::io;
  const auto accepted = [](const Eigen::Matrix4d& m) {
    if (!poseProblem(m).empty())
      return;
    const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
    const bool rigid =
        m.allFinite() && m.row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1), 0) &&
        ((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <=
         kRigidMotionTolerance) &&
        r.determinant() > 0.0 && m.topRightCorner<3, 1>().norm() <= kMaxPoseTranslation;
    if (!rigid)
      std::abort();
  };
  if (size >= 16 * sizeof(double)) {
    Eigen::Matrix4d m;
    std::memcpy(m.data(), data, sizeof(double) * 16);
    accepted(m);
  }
  writeFile(input_path, reinterpret_cast<const char*>(data), size);
  try {
    for (const auto& pose : loadKittiPoses(input_path))
      accepted(pose);
  }
  catch (const std::exception&) {
  }
}

void
checkCloud(const pcl::PointCloud<pcl::PointXYZ>& cloud)
{
  // The readers promise an unorganised dense cloud of finite points.
  if (cloud.width != cloud.size() || cloud.height != 1 || !cloud.is_dense)
    std::abort();
  for (const auto& p : cloud)
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      std::abort();
}

void
read(const std::string& path)
{
  using namespace pcl_parallel::io;
  if (format_name == "uos_pose") {
    if (!loadUosPose(path).allFinite())
      std::abort();
  }
  else if (format_name == "frames") {
    if (!loadFramesFinalPose(path).allFinite())
      std::abort();
  }
  else if (format_name == "kitti_poses") {
    for (const auto& pose : loadKittiPoses(path))
      if (!pose.allFinite())
        std::abort();
  }
  else if (format_name == "kitti_times") {
    for (double t : loadKittiTimes(path))
      if (!std::isfinite(t))
        std::abort();
  }
  else if (format_name == "tum") {
    checkTrajectory(loadTumTrajectory(path), true);
  }
  else if (format_name == "frames_history") {
    // Two readers of .frames: they accept the same files, and with unit 1 their final
    // poses agree.
    std::vector<Eigen::Matrix4d> history;
    Eigen::Matrix4d final_pose;
    bool history_read = false, final_read = false;
    try {
      history = loadFrames(path, 1.0);
      history_read = true;
    }
    catch (const std::runtime_error&) {
    }
    try {
      final_pose = loadFramesFinalPose(path);
      final_read = true;
    }
    catch (const std::runtime_error&) {
    }
    if (history_read != final_read)
      std::abort();
    if (history_read) {
      checkTrajectory({history, {}, PoseFileFormat::Frames}, false);
      if (history.back() != final_pose)
        std::abort();
    }
  }
  else if (format_name == "trajectory" || format_name == "frames_dir") {
    const Trajectory t = loadTrajectory(path);
    checkTrajectory(t, t.format == PoseFileFormat::Tum);
  }
  else if (format_name == "carmen") {
    // Scans as every reader's; poses and time stamps finite.
    const CarmenLog log = loadCarmenLog(path);
    for (const CarmenScan& s : log.scans) {
      checkCloud(*s.cloud);
      if (!s.laser_pose.allFinite() || !s.robot_pose.allFinite() ||
          !s.laser_offset.allFinite() || !std::isfinite(s.timestamp) ||
          s.cloud->size() > s.beams)
        std::abort();
    }
    for (const CarmenOdometry& o : log.odometry)
      if (!o.pose.allFinite() || !std::isfinite(o.timestamp))
        std::abort();
  }
  else if (format_name == "relations") {
    for (const auto& r : pcl_parallel::evaluation::loadRelations(path))
      if (!r.motion.allFinite() || !std::isfinite(r.t1) || !std::isfinite(r.t2))
        std::abort();
  }
  else if (format_name == "stanford_conf") {
    for (const auto& entry : loadStanfordConf(path))
      if (!entry.pose.allFinite())
        std::abort();
  }
  else {
    // The scan formats through loadScan (the extension picks the reader), once unfiltered
    // and once with a range filter and the per-point times: one finite time a point, or
    // none.
    checkCloud(*loadScan(path));
    std::vector<double> times;
    const auto timed = loadScan(path, 0.5, 100.0, &times);
    checkCloud(*timed);
    if (!times.empty() &&
        (times.size() != timed->size() ||
         !std::all_of(times.begin(), times.end(), [](double t) { return std::isfinite(t); })))
      std::abort();
  }
}

} // namespace

void
initialize(const char* format)
{
  static const std::pair<const char*, const char*> kFormats[] = {{"uos_scan", ".3d"},
                                                                 {"uos_pose", ".pose"},
                                                                 {"frames", ".frames"},
                                                                 {"xyz", ".xyz"},
                                                                 {"kitti_scan", ".bin"},
                                                                 {"kitti_poses", ".txt"},
                                                                 {"stanford_conf", ".conf"},
                                                                 {"pcd", ".pcd"},
                                                                 {"ply", ".ply"},
                                                                 {"tum", ".tum"},
                                                                 {"kitti_times", ".txt"},
                                                                 {"frames_history", ".frames"},
                                                                 {"trajectory", ".txt"},
                                                                 {"frames_dir", "_dir"},
                                                                 {"evaluate", "_evaluate"},
                                                                 {"options", "_options"},
                                                                 {"poses", "_poses.txt"},
                                                                 {"carmen", ".clf"},
                                                                 {"relations", ".relations"}};
  format_name = format;
  for (const auto& [name, ext] : kFormats)
    if (format_name == name)
      extension = ext;
  if (extension.empty())
    std::abort(); // a harness built for a format this file does not know
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); // PCL's readers print a lot
  const std::filesystem::path dir =
      std::filesystem::exists("/dev/shm") ? "/dev/shm" : std::filesystem::temp_directory_path();
  input_path = (dir / ("pcl_parallel_fuzz_" + std::to_string(::getpid()) + extension)).string();
  std::atexit([] {
    std::error_code ec;
    fs::remove_all(input_path, ec);
    fs::remove(input_path + "_estimate.txt", ec);
    fs::remove(input_path + "_truth.txt", ec);
  });
}

void
testOneInput(const std::uint8_t* data, std::size_t size)
{
  if (format_name == "evaluate" || format_name == "options" || format_name == "poses") {
    format_name == "evaluate"  ? evaluate(data, size)
    : format_name == "options" ? options(data, size)
                               : poses(data, size);
    return;
  }
  if (format_name == "frames_dir")
    writeDirectory(data, size);
  else
    writeFile(input_path, reinterpret_cast<const char*>(data), size);
  try {
    read(input_path);
  }
  catch (const std::exception&) {
    // A clear error is the expected answer to a bad file.
  }
}

} // namespace pcl_parallel_fuzz
