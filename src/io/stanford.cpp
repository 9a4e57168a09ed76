/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "detail.h"

#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/stanford.h>

#include <Eigen/Geometry>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace pcl_parallel {
namespace io {

std::vector<StanfordConfEntry>
loadStanfordConf(const std::string& path)
{
  using detail::fail;
  std::vector<StanfordConfEntry> out;
  detail::forEachLine(path, [&](const std::string& line, std::size_t line_no) {
    // scanalyze writes "camera t q" and "bmesh FILE t q"; anything else is not a .conf line.
    detail::Fields fields(line);
    std::string_view kind, file, f;
    fields.next(kind);
    if (kind != "bmesh" && kind != "camera")
      fail(path,
           line_no,
           "expected \"bmesh FILE tx ty tz qx qy qz qw\" or \"camera ...\", got " +
               detail::quoted(line));
    if (kind == "bmesh" && !fields.next(file))
      fail(path, line_no, "bmesh line without a file name");
    double v[7];
    std::size_t k = 0;
    while (fields.next(f)) {
      if (k == 7 || !detail::parseNumber(f, v[k]) || !std::isfinite(v[k]))
        fail(path,
             line_no,
             "expected 7 finite numbers (tx ty tz qx qy qz qw), got " + detail::quoted(line));
      ++k;
    }
    if (k != 7)
      fail(
          path, line_no, "expected 7 numbers (tx ty tz qx qy qz qw), got " + std::to_string(k));
    if (kind == "camera")
      return;
    const Eigen::Quaterniond quat(v[6], v[3], v[4], v[5]); // (w, x, y, z)
    if (!(quat.norm() > 0.5 && quat.norm() < 2.0))
      fail(path, line_no, "not a unit quaternion (norm " + std::to_string(quat.norm()) + ")");
    StanfordConfEntry e;
    e.file = std::string(file);
    e.pose.setIdentity();
    e.pose.topLeftCorner<3, 3>() = quat.normalized().toRotationMatrix().transpose();
    e.pose.topRightCorner<3, 1>() = Eigen::Vector3d(v[0], v[1], v[2]);
    out.push_back(e);
  });
  if (out.empty())
    fail(path, 0, "no bmesh lines");
  return out;
}

Eigen::Matrix4d
stanfordPose(const std::vector<StanfordConfEntry>& entries, const std::string& file)
{
  for (const auto& e : entries)
    if (e.file == file)
      return e.pose;
  throw std::out_of_range("pcl_parallel::io::stanfordPose: " + file + " is not in the .conf");
}

pcl::PointCloud<pcl::PointXYZ>::Ptr
loadStanfordScan(const std::string& path)
{
  // loadScan: the file checks and allocation guard around loadPlyScan.
  const pcl::PointCloud<pcl::PointXYZ>::Ptr out = loadScan(path);
  if (out->empty())
    detail::fail(path, 0, "no finite points");
  return out;
}

} // namespace io
} // namespace pcl_parallel
