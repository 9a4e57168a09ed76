/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "input.h"

#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/uos.h>
#include <pcl_parallel/sim/presets.h>
#include <pcl_parallel/sim/scan_set_writer.h>
#include <pcl_parallel/sim/simulated_scans.h>
#include <pcl_parallel/slam/preprocess.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <optional>
#include <sstream>
#include <unistd.h>

namespace fs = std::filesystem;

namespace pcl_pslam {

namespace {

/** The library's readers say "pcl_parallel::io: FILE:LINE: problem"; the app's one line
 *  starts with "pcl_pslam: " already. */
std::string
withoutPrefix(const std::string& what)
{
  const std::string prefix = "pcl_parallel::io: ";
  return what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what;
}

/** The number at the end of a file's stem (scan012 -> 12, 000042 -> 42), -1 if none. */
long
trailingNumber(const fs::path& file)
{
  const std::string stem = file.stem().string();
  std::size_t k = stem.size();
  while (k > 0 && std::isdigit(static_cast<unsigned char>(stem[k - 1])))
    --k;
  if (k == stem.size() || stem.size() - k > 9)
    return -1;
  return std::stol(stem.substr(k));
}

/** The files' trailing numbers, where every file has one and no two share it; else none. */
std::optional<std::vector<long>>
distinctNumbers(const std::vector<fs::path>& files)
{
  std::vector<long> numbers;
  for (const auto& f : files)
    numbers.push_back(trailingNumber(f));
  std::vector<long> sorted = numbers;
  std::sort(sorted.begin(), sorted.end());
  if (!sorted.empty() &&
      (sorted.front() < 0 || std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()))
    return std::nullopt;
  return numbers;
}

/** Sorts scan files as a user numbered them: by their trailing numbers where every stem
 *  is one prefix and a distinct number (scan2 before scan10, as 3DTK's scanNNN), else by
 *  name. A prefix ending in '.' makes the number a decimal fraction (1317384506.25), whose
 *  name order is right. */
void
sortScanFiles(std::vector<fs::path>& files)
{
  std::sort(files.begin(), files.end());
  const auto prefix = [](const fs::path& f) {
    const std::string stem = f.stem().string();
    return stem.substr(0, stem.find_last_not_of("0123456789") + 1);
  };
  for (const auto& f : files) {
    const std::string p = prefix(f);
    if (p != prefix(files.front()) || (!p.empty() && p.back() == '.'))
      return;
  }
  const auto numbers = distinctNumbers(files);
  if (!numbers) // a name without a number, or scan1 and scan01: the names decide
    return;
  std::vector<std::size_t> order(files.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return (*numbers)[a] < (*numbers)[b];
  });
  std::vector<fs::path> sorted;
  for (const std::size_t i : order)
    sorted.push_back(files[i]);
  files = std::move(sorted);
}

/** One timestamp (seconds) per non-blank line (io::loadKittiTimes). */
std::vector<double>
readTimes(const std::string& path)
{
  try {
    return pcl_parallel::io::loadKittiTimes(path);
  }
  catch (const std::runtime_error& e) {
    throw DataError(withoutPrefix(e.what()));
  }
}

} // namespace

namespace {

/** The scan files of o.dir in reading order (sortScanFiles) and their format: -f, else
 *  the most common scan extension (.txt only when asked for: it also names notes and pose
 *  lists). Not only regular files: a directory or dangling link named like a scan is
 *  reported by the reader when its turn comes, not silently left out. */
std::pair<std::string, std::vector<fs::path>>
listScanFiles(const Options& o)
{
  std::map<std::string, std::vector<fs::path>> by_ext;
  std::error_code ec;
  for (fs::directory_iterator it(o.dir, ec), end; !ec && it != end; it.increment(ec))
    if (pcl_parallel::io::isScanFile(it->path().string()))
      by_ext[lowerCase(it->path().extension().string().substr(1))].push_back(it->path());
  if (ec)
    throw DataError(o.dir + ": cannot list the directory (" + ec.message() + ")");
  std::string format = o.format;
  if (format.empty()) {
    std::size_t best = 0;
    for (const auto& [ext, list] : by_ext) {
      if (ext == "txt")
        continue;
      if (list.size() > best)
        best = list.size(), format = ext;
      else if (list.size() == best && best > 0)
        throw UsageError(o.dir + ": holds " + std::to_string(best) + " ." + format + " and " +
                         std::to_string(best) + " ." + ext + " files; choose one with -f");
    }
  }
  std::vector<fs::path> files = by_ext[format];
  sortScanFiles(files);
  if (files.empty())
    throw DataError(o.dir + ": no scan files" + (format.empty() ? "" : " (." + format + ")"));
  if (files.size() < 2)
    throw DataError(o.dir + ": 1 ." + format + " scan file; pcl_pslam needs at least 2");
  return {format, files};
}

/** Scan numbers for -s/-e: the numbers in the names when every file has a distinct one
 *  (3DTK's scanNNN), else the positions. */
std::vector<long>
scanNumbers(const std::vector<fs::path>& files)
{
  if (auto numbers = distinctNumbers(files))
    return *numbers;
  std::vector<long> positions(files.size());
  std::iota(positions.begin(), positions.end(), 0L);
  return positions;
}

/** --poses: KITTI or TUM (io::detectPoseFileFormat), one pose per scan file in the
 *  directory (before -s/-e), TUM's timestamps with them; none without it. */
pcl_parallel::io::Trajectory
readPosesFile(const Options& o, std::size_t files, const std::string& format)
{
  if (o.poses_file.empty())
    return {};
  pcl_parallel::io::Trajectory odometry;
  try {
    odometry = pcl_parallel::io::loadTrajectory(o.poses_file);
  }
  catch (const std::runtime_error& e) {
    throw DataError(withoutPrefix(e.what()));
  }
  if (odometry.poses.size() != files)
    throw DataError(o.poses_file + ": " + std::to_string(odometry.poses.size()) +
                    " poses for " + std::to_string(files) + " ." + format + " scans in " +
                    o.dir);
  return odometry;
}

/** --times, else times.txt in the directory or its parent (KITTI's sequences/NN/ beside
 *  velodyne/): one stamp per scan file; a times.txt found by itself that does not fit is
 *  not ours and ignored. */
std::vector<double>
readScanTimes(const Options& o, std::size_t files)
{
  std::string path = o.times_file;
  if (path.empty())
    for (const fs::path& d : {fs::path(o.dir), fs::absolute(o.dir).parent_path()})
      if (fs::is_regular_file(d / "times.txt")) {
        path = (d / "times.txt").string();
        break;
      }
  if (path.empty())
    return {};
  std::vector<double> times = readTimes(path);
  if (times.size() != files) {
    if (!o.times_file.empty())
      throw DataError(path + ": " + std::to_string(times.size()) + " timestamps for " +
                      std::to_string(files) + " scans in " + o.dir);
    times.clear();
  }
  return times;
}

/** The 3DTK .pose file beside a .3d scan, translation times `scale`; none if absent. */
std::optional<Eigen::Matrix4d>
uosPose(const fs::path& scan, double scale)
{
  fs::path pose = scan;
  pose.replace_extension(".pose");
  if (!fs::exists(pose))
    return std::nullopt;
  Eigen::Matrix4d m;
  try {
    m = pcl_parallel::io::loadUosPose(pose.string());
  }
  catch (const std::runtime_error& e) {
    throw DataError(withoutPrefix(e.what()));
  }
  m.topRightCorner<3, 1>() *= scale;
  return m;
}

} // namespace

Input
openDirectory(const Options& o)
{
  if (!fs::is_directory(o.dir))
    throw UsageError(o.dir + ": " +
                     (fs::exists(o.dir) ? "not a directory" : "no such directory"));
  for (const std::string& f : {o.poses_file, o.times_file})
    if (!f.empty() && !fs::is_regular_file(f))
      throw UsageError(f + ": no such file");
  if (std::error_code ec; !o.out.empty() && fs::equivalent(o.out, o.dir, ec))
    throw UsageError(o.out + ": --out is the scan directory, whose map.pcd the next run "
                             "would read as a scan; choose another");
  const auto [format, files] = listScanFiles(o);
  Input in;
  in.format = format;
  const bool uos = format == "3d";
  in.scale = o.scale ? *o.scale : uos ? 0.01 : 1.0;
  in.up = o.up >= 0 ? o.up : uos ? 1 : 2;
  in.frames_3dtk = uos;
  in.min_range = o.min_range;
  in.max_range = o.max_range;
  const std::vector<long> numbers = scanNumbers(files);
  const auto odometry = readPosesFile(o, files.size(), format);
  const Poses& all_poses = odometry.poses;
  std::vector<double> all_times = readScanTimes(o, files.size());
  if (all_times.empty()) // a TUM odometry's stamps are its scans'
    all_times = odometry.timestamps;

  std::vector<std::size_t> selected;
  for (std::size_t i = 0; i < files.size(); ++i)
    if (numbers[i] >= o.first && (o.last < 0 || numbers[i] <= o.last))
      selected.push_back(i);
  if (selected.size() < 2) // the scans are there: -s/-e chose too few
    throw UsageError(o.dir + ": " + std::to_string(selected.size()) + " of its " +
                     std::to_string(files.size()) + " ." + format +
                     " scans lie in the range -s " + std::to_string(o.first) +
                     (o.last >= 0 ? " -e " + std::to_string(o.last) : "") +
                     "; pcl_pslam needs at least 2");
  bool have_uos_poses = uos && all_poses.empty() && !o.no_poses;
  for (const std::size_t i : selected) {
    in.files.push_back(files[i].string());
    in.numbers.push_back(static_cast<int>(numbers[i]));
    in.stamps.push_back(all_times.empty() ? static_cast<double>(numbers[i]) : all_times[i]);
    if (have_uos_poses) {
      if (const auto pose = uosPose(files[i], in.scale))
        in.initial.push_back(*pose);
      else if (!in.initial.empty())
        throw DataError(fs::path(files[i]).replace_extension(".pose").string() +
                        ": missing (the scans before it have .pose files)");
      else
        have_uos_poses = false;
    }
    else if (!all_poses.empty()) {
      Eigen::Matrix4d m = all_poses[i];
      m.topRightCorner<3, 1>() *= in.scale;
      in.initial.push_back(m);
    }
  }
  in.has_stamps = !all_times.empty();
  if (in.initial.empty()) { // no odometry: constant-velocity guesses
    in.initial.assign(in.files.size(), Eigen::Matrix4d::Identity());
    in.odometry = false;
  }
  return in;
}

Cloud::Ptr
readScan(const Input& in, std::size_t k, std::vector<double>* point_times)
{
  const std::string& file = in.files.at(k);
  Cloud::Ptr cloud;
  try {
    cloud = pcl_parallel::io::loadScan(file, in.min_range, in.max_range, point_times);
  }
  catch (const std::exception& e) {
    throw DataError(withoutPrefix(e.what()));
  }
  if (cloud->empty())
    throw DataError(file + ": no finite points" +
                    (in.min_range > 0 || std::isfinite(in.max_range)
                         ? " within the range limits (-M/-m)"
                         : ""));
  try {
    pcl_parallel::slam::requireScannerFrame(*cloud, file, 1); // on the reading thread
  }
  catch (const std::invalid_argument& e) {
    throw DataError(e.what());
  }
  const float s = static_cast<float>(in.scale);
  for (auto& p : *cloud)
    p.getVector3fMap() *= s;
  return cloud;
}

std::string
deskewNote(const Input& in, bool deskew)
{
  if (!deskew)
    return in.timed_scans == 0
               ? ""
               : "the scans carry per-point times: --deskew would deskew each "
                 "point by its own (unless they are motion-compensated already)";
  if (in.timed_scans == in.size())
    return "deskewed by the points' time field";
  if (in.timed_scans == 0)
    return "deskewed by azimuth (no per-point times in the scans)";
  return "deskewed by the points' time field in " + std::to_string(in.timed_scans) + " of " +
         std::to_string(in.size()) + " scans, else by azimuth";
}

std::string
keyframeWarning(const Input& in, bool deskew, double sweep_period)
{
  if (!deskew || sweep_period > 0.0 || !in.has_stamps || in.stamps.size() < 2)
    return "";
  std::vector<double> gaps;
  for (std::size_t k = 1; k < in.stamps.size(); ++k)
    gaps.push_back(in.stamps[k] - in.stamps[k - 1]);
  const double gap = pcl_parallel::slam::median(gaps);
  if (!(gap > kMaxSweepSeconds))
    return "";
  char text[320];
  std::snprintf(text,
                sizeof text,
                "the scans are a median %.2f s apart, longer than a LiDAR sweep: if they are "
                "keyframes, --deskew bends each by its whole step; give the sweep's period "
                "(--sweep-period 0.1 for a 10 Hz LiDAR)",
                gap);
  return text;
}

std::vector<Cloud::Ptr>
readAllScans(const Input& in)
{
  std::vector<Cloud::Ptr> scans;
  for (std::size_t k = 0; k < in.size(); ++k)
    scans.push_back(readScan(in, k));
  return scans;
}

std::string
simulateDemo(Options& o)
{
  const auto names = pcl_parallel::sim::presetNames();
  if (std::find(names.begin(), names.end(), o.preset) == names.end())
    throw UsageError("--preset: unknown preset '" + o.preset + "' (pcl_pslam simulate --list)");
  std::string dir = o.keep;
  if (dir.empty()) {
    std::error_code ec;
    for (int k = 0; dir.empty() || fs::exists(dir, ec); ++k)
      dir = (fs::temp_directory_path() /
             ("pcl_pslam_demo_" + std::to_string(::getpid()) + "_" + std::to_string(k)))
                .string();
  }
  pcl_parallel::sim::PresetOptions options;
  options.num_threads = o.threads;
  const auto set = pcl_parallel::sim::simulatePreset(o.preset, options);
  pcl_parallel::sim::writeScanSet(set, dir);
  o.dir = dir;
  if (!set.point_times.empty()) { // KITTI-like: odometry.txt beside, raw sweeps
    if (!o.no_poses)
      o.poses_file = (fs::path(dir) / "odometry.txt").string();
    o.deskew = true;
  }
  return dir;
}

} // namespace pcl_pslam
