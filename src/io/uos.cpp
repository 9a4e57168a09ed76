/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "detail.h"

#include <pcl_parallel/io/uos.h>

#include <Eigen/Geometry>

#include <cmath>
#include <stdexcept>
#include <string_view>

namespace pcl_parallel {
namespace io {

namespace {

using detail::fail;

/** 3DTK's optional uos header, "W x H" (the scan's grid size): two integers and an 'x',
 *  with or without spaces. */
bool
isGridHeader(const std::string& line)
{
  detail::Fields fields(line);
  std::string_view f[4];
  std::size_t k = 0;
  while (k < 4 && fields.next(f[k]))
    ++k;
  if (k == 1) { // "WxH" written without spaces
    const std::size_t x = f[0].find_first_of("xX");
    if (x == std::string_view::npos)
      return false;
    f[2] = f[0].substr(x + 1);
    f[0] = f[0].substr(0, x);
    f[1] = "x";
    k = 3;
  }
  double w, h;
  return k == 3 && (f[1] == "x" || f[1] == "X") && detail::parseNumber(f[0], w) &&
         detail::parseNumber(f[2], h) && w >= 0 && h >= 0 && w == std::floor(w) &&
         h == std::floor(h);
}

} // namespace

pcl::PointCloud<pcl::PointXYZ>::Ptr
loadUosScan(const std::string& path, double min_range, double max_range)
{
  detail::RangeFilteredCloud cloud(path, min_range, max_range);
  bool first = true;
  std::size_t points = 0;
  detail::forEachLine(path, [&](const std::string& line, std::size_t line_no) {
    const bool header = first && isGridHeader(line);
    first = false;
    if (header)
      return;
    double v[3];
    if (detail::parseNumbers(line, v, 3) != 3)
      fail(path, line_no, "expected three numbers \"x y z\", got " + detail::quoted(line));
    ++points;
    cloud.add(v[0], v[1], v[2], line_no); // NaN or inf: a no-return, dropped as everywhere
  });
  if (points == 0)
    fail(path, 0, "no points (an empty or header-only .3d file)");
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
  double v[6];
  std::size_t k = 0;
  detail::forEachLine(path, [&](const std::string& line, std::size_t line_no) {
    detail::Fields fields(line);
    std::string_view field;
    while (fields.next(field)) {
      if (k == 6)
        fail(path, line_no, "more than 6 numbers (x y z, then θx θy θz in degrees)");
      if (!detail::parseNumber(field, v[k]) || !std::isfinite(v[k]))
        fail(path, line_no, "not a finite number: " + detail::quoted(field));
      ++k;
    }
  });
  if (k != 6)
    fail(path,
         0,
         "expected 6 numbers (x y z, then θx θy θz in degrees), got " + std::to_string(k));
  constexpr double kDegToRad = M_PI / 180.0;
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  pose.topLeftCorner<3, 3>() =
      eulerToRotation3dtk(v[3] * kDegToRad, v[4] * kDegToRad, v[5] * kDegToRad);
  pose.topRightCorner<3, 1>() = Eigen::Vector3d(v[0], v[1], v[2]);
  return pose;
}

} // namespace io
} // namespace pcl_parallel
