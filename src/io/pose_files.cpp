/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "detail.h"
#include "file_names.h"

#include <pcl_parallel/io/atomic_write.h>
#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/io/scan_io.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <string_view>
#include <system_error>
#include <tuple>

namespace pcl_parallel {
namespace io {

namespace fs = std::filesystem;

namespace {

using detail::fail;

/** The fields of a line, separated as in every text format (detail::Fields: white space
 *  or a comma). */
std::vector<std::string_view>
splitFields(const std::string& line)
{
  std::vector<std::string_view> fields;
  detail::Fields parser(line);
  std::string_view field;
  while (parser.next(field))
    fields.push_back(field);
  return fields;
}

/** A whole field as a finite double: the one number parser of the text formats. */
bool
parseFinite(std::string_view field, double& value)
{
  return detail::parseNumber(field, value) && std::isfinite(value);
}

/** Parses exactly n finite numbers (the first `optional` further fields are allowed and
 *  ignored when they are numbers), or fails naming the line and the column. */
void
parseLine(const std::string& path,
          std::size_t line_no,
          const std::string& line,
          double* out,
          std::size_t n,
          std::size_t optional,
          const char* layout)
{
  const std::vector<std::string_view> fields = splitFields(line);
  if (fields.size() < n || fields.size() > n + optional)
    fail(path,
         line_no,
         "expected " + std::to_string(n) + " numbers (" + layout + "), got " +
             std::to_string(fields.size()) + " fields");
  for (std::size_t k = 0; k < fields.size(); ++k) {
    double v;
    if (!parseFinite(fields[k], v))
      fail(path,
           line_no,
           "column " + std::to_string(k + 1) +
               " is not a finite number: " + detail::quoted(fields[k]));
    if (k < n)
      out[k] = v;
  }
}

bool
isComment(const std::string& line)
{
  const std::size_t pos = line.find_first_not_of(detail::kSpace);
  return pos != std::string::npos && line[pos] == '#';
}

/** Shortest decimal form that reads back to the same double (std::to_chars), or with
 *  `digits` > 0 that many significant digits as printf's %.*g in the C locale. */
void
writeNumber(std::ostream& out, double v, int digits = 0)
{
  char buf[40];
  const auto res =
      digits > 0 ? std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::general, digits)
                 : std::to_chars(buf, buf + sizeof(buf), v);
  out.write(buf, res.ptr - buf);
}

void
requireExisting(const std::string& path)
{
  std::error_code ec;
  if (!fs::exists(path, ec))
    fail(path, 0, "no such file or directory");
}

} // namespace

std::string
toString(PoseFileFormat format)
{
  switch (format) {
  case PoseFileFormat::Kitti:
    return "kitti";
  case PoseFileFormat::Tum:
    return "tum";
  case PoseFileFormat::Frames:
    return "frames";
  }
  return "?";
}

namespace {

/** Writers refuse a non-finite pose before creating any file: no NaN in an output. */
void
requireFinite(const std::string& path, const std::vector<Eigen::Matrix4d>& poses)
{
  for (std::size_t i = 0; i < poses.size(); ++i)
    if (!poses[i].allFinite())
      throw std::invalid_argument("pcl_parallel::io: " + path + ": pose " + std::to_string(i) +
                                  " is not finite");
}

} // namespace

void
writeKittiPoses(const std::string& path, const std::vector<Eigen::Matrix4d>& poses)
{
  requireFinite(path, poses);
  writeStreamAtomically(path, [&](std::ostream& out) {
    for (const auto& p : poses)
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c) {
          writeNumber(out, p(r, c));
          out << (r == 2 && c == 3 ? '\n' : ' ');
        }
  });
}

std::vector<double>
loadKittiTimes(const std::string& path)
{
  requireExisting(path);
  std::vector<double> times;
  detail::forEachLine(path, [&](const std::string& line, std::size_t line_no) {
    double t;
    parseLine(path, line_no, line, &t, 1, 0, "a timestamp in seconds");
    times.push_back(t);
  });
  return times;
}

Trajectory
loadTumTrajectory(const std::string& path)
{
  requireExisting(path);
  Trajectory t;
  t.format = PoseFileFormat::Tum;
  detail::forEachLine(path, [&](const std::string& line, std::size_t line_no) {
    if (isComment(line))
      return;
    double v[8];
    parseLine(path, line_no, line, v, 8, 0, "timestamp tx ty tz qx qy qz qw");
    Eigen::Quaterniond q(v[7], v[4], v[5], v[6]); // Eigen: (w, x, y, z)
    const double norm = q.norm();
    if (!(std::abs(norm - 1.0) <= 0.01))
      fail(path,
           line_no,
           "the quaternion (qx qy qz qw) has norm " + std::to_string(norm) +
               ", not 1: a missing column or another order?");
    q.normalize();
    Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
    pose.topLeftCorner<3, 3>() = q.toRotationMatrix();
    pose.topRightCorner<3, 1>() = Eigen::Vector3d(v[1], v[2], v[3]);
    t.timestamps.push_back(v[0]);
    t.poses.push_back(pose);
  });
  return t;
}

void
writeTumTrajectory(const std::string& path,
                   const std::vector<Eigen::Matrix4d>& poses,
                   const std::vector<double>& timestamps)
{
  if (!timestamps.empty() && timestamps.size() != poses.size())
    throw std::invalid_argument("pcl_parallel::io::writeTumTrajectory: " + path + ": " +
                                std::to_string(timestamps.size()) + " timestamps for " +
                                std::to_string(poses.size()) + " poses");
  requireFinite(path, poses);
  writeStreamAtomically(path, [&](std::ostream& out) {
    out << "# timestamp tx ty tz qx qy qz qw\n";
    for (std::size_t i = 0; i < poses.size(); ++i) {
      const Eigen::Matrix3d r = poses[i].topLeftCorner<3, 3>();
      const Eigen::Quaterniond q(r);
      const double v[8] = {timestamps.empty() ? static_cast<double>(i) : timestamps[i],
                           poses[i](0, 3),
                           poses[i](1, 3),
                           poses[i](2, 3),
                           q.x(),
                           q.y(),
                           q.z(),
                           q.w()};
      for (int k = 0; k < 8; ++k) {
        writeNumber(out, v[k]);
        out << (k == 7 ? '\n' : ' ');
      }
    }
  });
}

std::vector<Eigen::Matrix4d>
loadFrames(const std::string& path, double unit)
{
  requireExisting(path);
  std::vector<Eigen::Matrix4d> history;
  detail::forEachLine(path, [&](const std::string& line, std::size_t line_no) {
    double v[16];
    parseLine(path, line_no, line, v, 16, 1, "a column-major 4x4 matrix, then a type code");
    Eigen::Matrix4d pose;
    for (int i = 0; i < 16; ++i)
      pose(i % 4, i / 4) = v[i];
    if (!detail::homogeneousLastRow(pose))
      fail(path, line_no, "columns 4, 8, 12, 16 (the last row) are not 0 0 0 1");
    pose.topRightCorner<3, 1>() *= unit;
    history.push_back(pose);
  });
  if (history.empty())
    fail(path, 0, "holds no frame (an empty .frames file)");
  return history;
}

void
writeFrames(const std::string& path, const std::vector<Frame>& frames, double unit, int digits)
{
  std::vector<Eigen::Matrix4d> poses;
  for (const auto& f : frames)
    poses.push_back(f.pose);
  requireFinite(path, poses);
  writeStreamAtomically(path, [&](std::ostream& out) {
    for (const auto& f : frames) {
      for (int i = 0; i < 16; ++i) { // column-major, as OpenGL and 3DTK
        const int r = i % 4, c = i / 4;
        writeNumber(out, c == 3 && r < 3 ? f.pose(r, c) / unit : f.pose(r, c), digits);
        out << ' ';
      }
      out << f.type << '\n';
    }
  });
}

void
writeFrames(const std::string& path,
            const std::vector<Eigen::Matrix4d>& history,
            double unit,
            int type)
{
  std::vector<Frame> frames;
  for (const auto& pose : history)
    frames.push_back({pose, type});
  writeFrames(path, frames, unit, 0);
}

void
writeScanFrames(const std::string& path,
                const Eigen::Matrix4d& initial,
                const Eigen::Matrix4d& icp,
                const Eigen::Matrix4d& final_pose,
                bool fixed,
                double unit)
{
  constexpr int kDigits = 12;
  const std::vector<Frame> frames = {{initial, kFramesInvalid},
                                     {icp, fixed ? kFramesIcpInactive : kFramesIcp},
                                     {final_pose, fixed ? kFramesIcpInactive : kFramesLum}};
  writeFrames(path, frames, unit, kDigits);
}

std::vector<std::string>
writeRunPoses(const std::string& dir,
              const std::vector<int>& numbers,
              const std::vector<Eigen::Matrix4d>& initial,
              const std::vector<Eigen::Matrix4d>& icp,
              const std::vector<Eigen::Matrix4d>& final_poses,
              const std::vector<double>& stamps,
              double frames_unit,
              const std::function<void()>& each)
{
  const auto path = [&](const std::string& name) { return (fs::path(dir) / name).string(); };
  for (std::size_t i = 0; i < numbers.size(); ++i) {
    std::string number = std::to_string(numbers[i]);
    number.insert(0, number.size() < 3 ? 3 - number.size() : 0, '0');
    writeScanFrames(path("scan" + number + ".frames"),
                    initial[i],
                    icp[i],
                    final_poses[i],
                    i == 0,
                    frames_unit);
    if (each)
      each();
  }
  writeKittiPoses(path("poses.txt"), final_poses);
  writeKittiPoses(path("poses_icp.txt"), icp);
  writeTumTrajectory(path("poses_tum.txt"), final_poses, stamps);
  writeTumTrajectory(path("poses_icp_tum.txt"), icp, stamps);
  return {"scanNNN.frames", "poses.txt", "poses_icp.txt", "poses_tum.txt", "poses_icp_tum.txt"};
}

Eigen::Matrix4d
loadFramesFinalPose(const std::string& path)
{
  return loadFrames(path, 1.0).back();
}

std::vector<Eigen::Matrix4d>
loadFramesDirectory(const std::string& dir, double unit)
{
  requireExisting(dir);
  // scanNNN.frames by number (3DTK pads to 3 digits, so scan1000 follows scan999), others
  // after them by name.
  std::vector<std::tuple<bool, unsigned long long, std::string>> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (entry.path().extension() != ".frames" || !entry.is_regular_file())
      continue;
    constexpr std::size_t kAround = std::string_view("scan.frames").size();
    if (detail::isNumberedName(name, "scan", 0, {".frames"}) && name.size() < kAround + 19)
      files.emplace_back(false, std::stoull(name.substr(4, name.size() - kAround)), name);
    else
      files.emplace_back(true, 0, name);
  }
  if (ec)
    fail(dir, 0, "cannot list the directory: " + ec.message());
  if (files.empty())
    fail(dir, 0, "holds no .frames files (3DTK's scanNNN.frames)");
  std::sort(files.begin(), files.end());
  std::vector<Eigen::Matrix4d> poses;
  for (const auto& f : files)
    poses.push_back(loadFrames((fs::path(dir) / std::get<2>(f)).string(), unit).back());
  return poses;
}

void
writeFramesDirectory(const std::string& dir,
                     const std::vector<Eigen::Matrix4d>& poses,
                     double unit,
                     int type,
                     std::size_t first_index)
{
  for (std::size_t i = 0; i < poses.size(); ++i) {
    std::string number = std::to_string(first_index + i);
    number.insert(0, number.size() < 3 ? 3 - number.size() : 0, '0');
    writeFrames(
        (fs::path(dir) / ("scan" + number + ".frames")).string(), {poses[i]}, unit, type);
  }
}

PoseFileFormat
detectPoseFileFormat(const std::string& path)
{
  requireExisting(path);
  if (fs::is_directory(path))
    return PoseFileFormat::Frames;
  const std::string ext = detail::lowerCaseExtension(path);
  if (ext == ".frames")
    fail(
        path, 0, "a .frames file holds one scan's poses; pass the directory of scanNNN.frames");
  if (ext == ".tum")
    return PoseFileFormat::Tum;
  if (ext == ".kitti")
    return PoseFileFormat::Kitti;
  bool found = false;
  PoseFileFormat format = PoseFileFormat::Kitti;
  std::size_t first_line = 0;
  std::size_t fields = 0;
  detail::forEachLine(path, [&](const std::string& line, std::size_t line_no) {
    if (found || first_line || isComment(line))
      return;
    first_line = line_no;
    fields = splitFields(line).size();
    found = fields == 8 || fields == 12;
    format = fields == 8 ? PoseFileFormat::Tum : PoseFileFormat::Kitti;
  });
  if (!first_line)
    fail(path, 0, "holds no poses (empty, or comments only)");
  if (!found)
    fail(path,
         first_line,
         "unknown pose file format: " + std::to_string(fields) +
             " fields (KITTI has 12 numbers a line, TUM 8: timestamp tx ty tz qx qy qz qw)");
  return format;
}

Trajectory
loadTrajectory(const std::string& path, double frames_unit)
{
  switch (detectPoseFileFormat(path)) {
  case PoseFileFormat::Tum:
    return loadTumTrajectory(path);
  case PoseFileFormat::Frames: {
    Trajectory t;
    t.format = PoseFileFormat::Frames;
    t.poses = loadFramesDirectory(path, frames_unit);
    return t;
  }
  case PoseFileFormat::Kitti:
    break;
  }
  Trajectory t;
  t.format = PoseFileFormat::Kitti;
  t.poses = loadKittiPoses(path);
  return t;
}

std::string
poseProblem(const Eigen::Matrix4d& pose)
{
  const Eigen::Matrix3d r = pose.topLeftCorner<3, 3>();
  if (!pose.allFinite())
    return "is not finite";
  if (!((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() <=
        kRigidMotionTolerance) ||
      !(r.determinant() > 0.0) || pose.row(3) != Eigen::RowVector4d(0, 0, 0, 1))
    return "is not a rigid motion (its rotation is not orthonormal within 1e-3, or a "
           "reflection)";
  if (!(pose.topRightCorner<3, 1>().cwiseAbs().maxCoeff() <= kMaxPoseTranslation))
    return "lies beyond 1e9 m";
  return {};
}

} // namespace io
} // namespace pcl_parallel
