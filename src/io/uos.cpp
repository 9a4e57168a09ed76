/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/io/uos.h>

#include <Eigen/Geometry>

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace pcl_parallel {
namespace io {

namespace {

[[noreturn]] void
fail(const std::string& path, std::size_t line, const std::string& what)
{
  std::ostringstream msg;
  msg << "pcl_parallel::io: " << path;
  if (line > 0)
    msg << ":" << line;
  msg << ": " << what;
  throw std::runtime_error(msg.str());
}

std::ifstream
openOrThrow(const std::string& path)
{
  std::ifstream in(path);
  if (!in)
    fail(path, 0, "cannot open file for reading");
  return in;
}

/** Parses up to n numbers from the start of a line; returns how many it read. */
std::size_t
parseNumbers(const std::string& line, double* out, std::size_t n)
{
  std::istringstream ss(line);
  std::size_t k = 0;
  while (k < n && ss >> out[k])
    ++k;
  return k;
}

} // namespace

pcl::PointCloud<pcl::PointXYZ>::Ptr
loadUosScan(const std::string& path, double min_range, double max_range)
{
  std::ifstream in = openOrThrow(path);
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  std::string line;
  std::size_t line_no = 0;
  std::size_t header_lines = 0;
  bool data_started = false;
  constexpr std::size_t kMaxHeaderLines = 10; // as 3DTK's ScanIO_uos
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") == std::string::npos)
      continue;
    double v[3];
    if (parseNumbers(line, v, 3) != 3 || !std::isfinite(v[0]) || !std::isfinite(v[1]) ||
        !std::isfinite(v[2])) {
      if (!data_started && ++header_lines <= kMaxHeaderLines)
        continue;
      fail(path, line_no, "expected three numbers \"x y z\", got \"" + line + "\"");
    }
    data_started = true;
    const double r = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (r < min_range || r > max_range)
      continue;
    cloud->push_back(pcl::PointXYZ(
        static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])));
  }
  if (in.bad())
    fail(path, line_no, "read error");
  cloud->width = static_cast<std::uint32_t>(cloud->size());
  cloud->height = 1;
  cloud->is_dense = true;
  return cloud;
}

Eigen::Matrix3d
eulerToRotation3dtk(double rx, double ry, double rz)
{
  return (Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

Eigen::Matrix4d
loadUosPose(const std::string& path)
{
  std::ifstream in = openOrThrow(path);
  double v[6];
  std::size_t k = 0;
  while (k < 6 && in >> v[k])
    ++k;
  if (k != 6)
    fail(path, 0, "expected 6 numbers (x y z, then θx θy θz in degrees)");
  for (double x : v)
    if (!std::isfinite(x))
      fail(path, 0, "non-finite value in pose");
  constexpr double kDegToRad = M_PI / 180.0;
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  pose.topLeftCorner<3, 3>() =
      eulerToRotation3dtk(v[3] * kDegToRad, v[4] * kDegToRad, v[5] * kDegToRad);
  pose.topRightCorner<3, 1>() = Eigen::Vector3d(v[0], v[1], v[2]);
  return pose;
}

Eigen::Matrix4d
loadFramesFinalPose(const std::string& path)
{
  std::ifstream in = openOrThrow(path);
  std::string line, last;
  std::size_t line_no = 0, last_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(" \t\r") != std::string::npos) {
      last = line;
      last_no = line_no;
    }
  }
  double v[17];
  if (last.empty() || parseNumbers(last, v, 17) < 16)
    fail(path, last_no, "expected 16 numbers (a column-major 4x4 matrix) and a type code");
  Eigen::Matrix4d pose;
  for (int i = 0; i < 16; ++i) {
    if (!std::isfinite(v[i]))
      fail(path, last_no, "non-finite value in frame");
    pose(i % 4, i / 4) = v[i];
  }
  return pose;
}

} // namespace io
} // namespace pcl_parallel
