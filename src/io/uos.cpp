/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "detail.h"

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

using detail::fail;
using detail::openOrThrow;

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
  detail::RangeFilteredCloud cloud(min_range, max_range);
  std::size_t header_lines = 0;
  bool data_started = false;
  constexpr std::size_t kMaxHeaderLines = 10; // as 3DTK's ScanIO_uos
  detail::forEachLine(path, [&](const std::string& line, std::size_t line_no) {
    double v[3];
    if (parseNumbers(line, v, 3) != 3 || !std::isfinite(v[0]) || !std::isfinite(v[1]) ||
        !std::isfinite(v[2])) {
      if (!data_started && ++header_lines <= kMaxHeaderLines)
        return;
      fail(path, line_no, "expected three numbers \"x y z\", got \"" + line + "\"");
    }
    data_started = true;
    cloud.add(v[0], v[1], v[2]);
  });
  return cloud.finish();
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
  std::string last;
  std::size_t last_no = 0;
  detail::forEachLine(path, [&](const std::string& line, std::size_t line_no) {
    last = line;
    last_no = line_no;
  });
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
