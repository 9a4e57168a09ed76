/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "detail.h"

#include <pcl_parallel/io/carmen.h>
#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/io/scan_directory.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/uos.h>
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/slam/preprocess.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <numeric>
#include <optional>

namespace pcl_parallel {
namespace io {

namespace fs = std::filesystem;

namespace {

/** The readers say "pcl_parallel::io: FILE:LINE: problem"; a ScanDataError is that
 *  message without the prefix (a caller's one line has its own). */
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

/** The scan files of o.dir in reading order (sortScanFiles) and their format: o.format,
 *  else the most common scan extension (.txt only when asked for: it also names notes and
 *  pose lists). Not only regular files: a directory or dangling link named like a scan is
 *  reported by the reader when its turn comes, not silently left out. */
std::pair<std::string, std::vector<fs::path>>
listScanFiles(const ScanDirectoryOptions& o)
{
  std::map<std::string, std::vector<fs::path>> by_ext;
  std::error_code ec;
  for (fs::directory_iterator it(o.dir, ec), end; !ec && it != end; it.increment(ec))
    if (isScanFile(it->path().string()))
      by_ext[detail::lowerCaseExtension(it->path().string()).substr(1)].push_back(it->path());
  if (ec)
    throw ScanDataError(o.dir + ": cannot list the directory (" + ec.message() + ")");
  std::string format = o.format;
  if (format.empty()) {
    std::size_t best = 0;
    for (const auto& [ext, list] : by_ext) {
      if (ext == "txt")
        continue;
      if (list.size() > best)
        best = list.size(), format = ext;
      else if (list.size() == best && best > 0)
        throw ScanDirectoryUsageError(o.dir + ": holds " + std::to_string(best) + " ." +
                                      format + " and " + std::to_string(best) + " ." + ext +
                                      " files; choose one with -f");
    }
  }
  std::vector<fs::path> files = by_ext[format];
  sortScanFiles(files);
  if (files.empty())
    throw ScanDataError(o.dir + ": no scan files" +
                        (format.empty() ? "" : " (." + format + ")"));
  if (files.size() < 2)
    throw ScanDataError(o.dir + ": 1 ." + format + " scan file; pcl_pslam needs at least 2");
  return {format, files};
}

/** Scan numbers for first/last: the numbers in the names when every file has a distinct
 *  one (3DTK's scanNNN), else the positions. */
std::vector<long>
scanNumbers(const std::vector<fs::path>& files)
{
  if (auto numbers = distinctNumbers(files))
    return *numbers;
  std::vector<long> positions(files.size());
  std::iota(positions.begin(), positions.end(), 0L);
  return positions;
}

/** o.poses_file: KITTI or TUM (detectPoseFileFormat), one pose per scan file in the
 *  directory (before first/last), TUM's timestamps with them; none without it. */
Trajectory
readPosesFile(const ScanDirectoryOptions& o, std::size_t files, const std::string& format)
{
  if (o.poses_file.empty())
    return {};
  Trajectory odometry;
  try {
    odometry = loadTrajectory(o.poses_file);
  }
  catch (const std::runtime_error& e) {
    throw ScanDataError(withoutPrefix(e.what()));
  }
  if (odometry.poses.size() != files)
    throw ScanDataError(o.poses_file + ": " + std::to_string(odometry.poses.size()) +
                        " poses for " + std::to_string(files) + " ." + format + " scans in " +
                        o.dir);
  return odometry;
}

/** o.times_file, else times.txt in the directory or its parent: one stamp per scan file
 *  in the directory (before first/last), whichever file gives them. */
std::vector<double>
readScanTimes(const ScanDirectoryOptions& o, std::size_t files)
{
  std::string path = o.times_file;
  std::error_code ec;
  if (path.empty())
    for (const fs::path& d : {fs::path(o.dir), fs::absolute(o.dir).parent_path()})
      if (fs::is_regular_file(d / "times.txt", ec)) {
        path = (d / "times.txt").string();
        break;
      }
  if (path.empty())
    return {};
  std::vector<double> times;
  try {
    times = loadKittiTimes(path);
  }
  catch (const std::runtime_error& e) {
    throw ScanDataError(withoutPrefix(e.what()));
  }
  if (times.size() != files)
    throw ScanDataError(path + ": " + std::to_string(times.size()) + " timestamps for " +
                        std::to_string(files) + " scans in " + o.dir +
                        (o.times_file.empty() ? " (a times.txt in their directory or its "
                                                "parent is taken as theirs)"
                                              : ""));
  return times;
}

/** `pose` (translation in metres), the `n`th of `file` (0: its only one), or a
 *  ScanDataError naming both when it is no pose (poseProblem). */
Eigen::Matrix4d
checkedPose(const Eigen::Matrix4d& pose, const std::string& file, std::size_t n)
{
  const std::string problem = poseProblem(pose);
  if (!problem.empty())
    throw ScanDataError(file + ": " +
                        (n > 0 ? "pose " + std::to_string(n) + " " : "the pose ") + problem);
  return pose;
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
    m = loadUosPose(pose.string());
  }
  catch (const std::runtime_error& e) {
    throw ScanDataError(withoutPrefix(e.what()));
  }
  m.topRightCorner<3, 1>() *= scale;
  return checkedPose(m, pose.string(), 0);
}

/** Whether any of the scan files has a 3DTK .pose file beside it. */
bool
anyUosPose(const std::vector<fs::path>& files)
{
  std::error_code ec;
  return std::any_of(files.begin(), files.end(), [&](fs::path f) {
    return fs::exists(f.replace_extension(".pose"), ec);
  });
}

/** The request's own checks, before the directory is listed. */
void
checkRequest(const ScanDirectoryOptions& o)
{
  std::error_code ec;
  const fs::file_status dir = fs::status(o.dir, ec);
  if (ec && ec != std::errc::no_such_file_or_directory) // a link loop, no permission
    throw ScanDirectoryUsageError(o.dir + ": " + ec.message());
  if (!fs::is_directory(dir))
    throw ScanDirectoryUsageError(o.dir + ": " +
                                  (fs::exists(dir) ? "not a directory" : "no such directory"));
  for (const std::string& f : {o.poses_file, o.times_file})
    if (!f.empty() && !fs::is_regular_file(f, ec))
      throw ScanDirectoryUsageError(f + ": no such file");
}

/** The indices of the files whose numbers lie in [o.first, o.last]: at least 2. */
std::vector<std::size_t>
selectScans(const ScanDirectoryOptions& o,
            const std::vector<long>& numbers,
            const std::string& format)
{
  std::vector<std::size_t> selected;
  for (std::size_t i = 0; i < numbers.size(); ++i)
    if (numbers[i] >= o.first && (o.last < 0 || numbers[i] <= o.last))
      selected.push_back(i);
  if (selected.size() < 2) // the scans are there: first/last chose too few
    throw ScanDirectoryUsageError(o.dir + ": " + std::to_string(selected.size()) + " of its " +
                                  std::to_string(numbers.size()) + " ." + format +
                                  " scans lie in the range -s " + std::to_string(o.first) +
                                  (o.last >= 0 ? " -e " + std::to_string(o.last) : "") +
                                  "; pcl_pslam needs at least 2");
  return selected;
}

/** Whether every point lies in the scanner's x-y plane: a 2D scan stored as 3D (z = 0,
 *  up to float rounding of a frame change). */
bool
liesInScannerPlane(const pcl::PointCloud<pcl::PointXYZ>& scan)
{
  return !scan.empty() && std::all_of(scan.begin(), scan.end(), [](const pcl::PointXYZ& p) {
    return std::abs(p.z) <= 1e-5f * p.getVector3fMap().norm();
  });
}

/** True where the odometry moved or turned enough from `from` to `to` (min_travel,
 *  min_turn). */
bool
movedEnough(const Eigen::Matrix4d& from,
            const Eigen::Matrix4d& to,
            const ScanDirectoryOptions& o)
{
  const Eigen::Matrix4d step = from.inverse() * to;
  return step.topRightCorner<3, 1>().norm() >= o.min_travel ||
         rotationAngle(step.topLeftCorner<3, 3>()) >= o.min_turn;
}

/** A CARMEN log's request: what a directory's options mean for it. */
void
checkLogRequest(const ScanDirectoryOptions& o)
{
  if (!o.poses_file.empty() || !o.times_file.empty())
    throw ScanDirectoryUsageError(o.dir + ": a CARMEN log holds its own odometry and time "
                                          "stamps (no --poses or --times)");
  if (!(o.min_travel >= 0.0 && o.min_turn >= 0.0 && std::isfinite(o.min_travel) &&
        std::isfinite(o.min_turn)))
    throw ScanDirectoryUsageError("the travel and turn between a log's scans must be finite "
                                  "and >= 0");
}

/** openScanDirectory for a CARMEN log: its laser scans in time order (the logs' lines are
 *  not in every log), numbered from 0, chosen by first/last, then by motion. A scan
 *  without a return is left out. */
ScanDirectory
openCarmenLog(const ScanDirectoryOptions& o)
{
  checkLogRequest(o);
  CarmenReadOptions read;
  read.min_range = o.min_range;
  read.max_range = std::min(read.max_range, o.max_range);
  CarmenLog log;
  try {
    log = loadCarmenLog(o.dir, read);
  }
  catch (const std::runtime_error& e) {
    throw ScanDataError(withoutPrefix(e.what()));
  }
  std::stable_sort(log.scans.begin(), log.scans.end(), [](const auto& a, const auto& b) {
    return a.timestamp < b.timestamp;
  });
  ScanDirectory in;
  in.format = "clf";
  in.planar = true;
  in.has_stamps = true;
  in.odometry = !o.no_poses;
  in.min_range = o.min_range;
  in.max_range = read.max_range;
  in.log_scans = log.scans.size();
  std::optional<Eigen::Matrix4d> last; // the odometry of the last scan kept
  std::size_t selected = 0;
  for (std::size_t i = 0; i < log.scans.size(); ++i) {
    const CarmenScan& scan = log.scans[i];
    if (static_cast<long>(i) < o.first || (o.last >= 0 && static_cast<long>(i) > o.last))
      continue;
    ++selected;
    if (scan.cloud->empty() || (last && !movedEnough(*last, scan.laser_pose, o)))
      continue;
    last = scan.laser_pose;
    in.files.push_back(o.dir + ":" + std::to_string(scan.line));
    in.numbers.push_back(static_cast<int>(i));
    in.stamps.push_back(scan.timestamp);
    in.initial.push_back(o.no_poses ? Eigen::Matrix4d::Identity() : scan.laser_pose);
    in.clouds.push_back(scan.cloud);
  }
  if (in.size() < 2)
    throw ScanDirectoryUsageError(
        o.dir + ": " + std::to_string(in.size()) + " of its " + std::to_string(selected) +
        " selected laser scans (of " + std::to_string(log.scans.size()) +
        ") have returns and lie apart by the travel or turn asked for; pcl_pslam needs at "
        "least 2");
  return in;
}

} // namespace

bool
isCarmenLogName(const std::string& path)
{
  std::string name = fs::path(path).filename().string();
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  const auto ends = [&](const std::string& suffix) {
    return name.size() > suffix.size() &&
           name.compare(name.size() - suffix.size(), suffix.size(), suffix) == 0;
  };
  return ends(".clf") || ends(".clf.bz2");
}

ScanDirectory
openScanDirectory(const ScanDirectoryOptions& request)
{
  if (std::error_code ec; isCarmenLogName(request.dir) && fs::is_regular_file(request.dir, ec))
    return openCarmenLog(request);
  checkRequest(request);
  ScanDirectoryOptions o = request;
  if (std::error_code ec; o.poses_file.empty() && !o.no_poses &&
                          fs::is_regular_file(fs::path(o.dir) / "odometry.txt", ec))
    o.poses_file = (fs::path(o.dir) / "odometry.txt").string(); // as `simulate` writes it
  const auto [format, files] = listScanFiles(o);
  ScanDirectory in;
  in.format = format;
  const bool uos = format == "3d";
  in.scale = o.scale ? *o.scale : uos ? 0.01 : 1.0;
  in.up = o.up >= 0 ? o.up : uos ? 1 : 2;
  in.frames_3dtk = uos;
  in.min_range = o.min_range;
  in.max_range = o.max_range;
  const std::vector<long> numbers = scanNumbers(files);
  const auto odometry = readPosesFile(o, files.size(), format);
  const std::vector<Eigen::Matrix4d>& all_poses = odometry.poses;
  std::vector<double> all_times = readScanTimes(o, files.size());
  if (all_times.empty()) // a TUM odometry's stamps are its scans'
    all_times = odometry.timestamps;
  bool have_uos_poses = uos && all_poses.empty() && !o.no_poses;
  for (const std::size_t i : selectScans(o, numbers, format)) {
    std::error_code ec; // an empty file has no points in any format: refused before the work
    if (fs::is_regular_file(files[i], ec) && fs::file_size(files[i], ec) == 0)
      throw ScanDataError(files[i].string() + ": empty file (no points)");
    in.files.push_back(files[i].string());
    in.numbers.push_back(static_cast<int>(numbers[i]));
    in.stamps.push_back(all_times.empty() ? static_cast<double>(numbers[i]) : all_times[i]);
    if (have_uos_poses) {
      if (const auto pose = uosPose(files[i], in.scale))
        in.initial.push_back(*pose);
      else if (!in.initial.empty() || anyUosPose(files))
        throw ScanDataError(fs::path(files[i]).replace_extension(".pose").string() +
                            ": missing (other scans have .pose files)");
      else
        have_uos_poses = false;
    }
    else if (!all_poses.empty()) {
      Eigen::Matrix4d m = all_poses[i];
      m.topRightCorner<3, 1>() *= in.scale;
      in.initial.push_back(checkedPose(m, o.poses_file, i + 1));
    }
  }
  in.has_stamps = !all_times.empty();
  in.poses_file = o.poses_file;
  if (in.initial.empty()) { // no odometry: constant-velocity guesses
    in.initial.assign(in.files.size(), Eigen::Matrix4d::Identity());
    in.odometry = false;
  }
  in.planar = in.up == 2 && liesInScannerPlane(*readScan(in, 0));
  return in;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr
readScan(const ScanDirectory& in, std::size_t k, std::vector<double>* point_times)
{
  const std::string& file = in.files.at(k);
  if (!in.clouds.empty()) { // a log's, read with it: no point times
    if (point_times)
      point_times->clear();
    return pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>(*in.clouds.at(k));
  }
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud;
  try {
    cloud = loadScan(file, in.min_range, in.max_range, point_times);
  }
  catch (const std::exception& e) {
    throw ScanDataError(withoutPrefix(e.what()));
  }
  if (cloud->empty())
    throw ScanDataError(file + ": no finite points" +
                        (in.min_range > 0 || std::isfinite(in.max_range)
                             ? " within the range limits (-M/-m)"
                             : ""));
  try {
    slam::requireScannerFrame(*cloud, file, 1); // on the reading thread
  }
  catch (const std::invalid_argument& e) {
    throw ScanDataError(e.what());
  }
  const float s = static_cast<float>(in.scale);
  for (auto& p : *cloud)
    p.getVector3fMap() *= s;
  return cloud;
}

std::vector<pcl::PointCloud<pcl::PointXYZ>::Ptr>
readAllScans(const ScanDirectory& in)
{
  std::vector<pcl::PointCloud<pcl::PointXYZ>::Ptr> scans;
  for (std::size_t k = 0; k < in.size(); ++k)
    scans.push_back(readScan(in, k));
  return scans;
}

} // namespace io
} // namespace pcl_parallel
