/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "detail.h"

#include <pcl_parallel/io/stanford.h>

#include <pcl/io/ply_io.h>

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
  std::ifstream in(path);
  if (!in)
    throw std::runtime_error("cannot open " + path);
  std::vector<StanfordConfEntry> out;
  std::string line;
  for (int line_no = 1; std::getline(in, line); ++line_no) {
    std::istringstream ss(line);
    std::string kind;
    if (!(ss >> kind) || kind != "bmesh")
      continue;
    StanfordConfEntry e;
    double t[3], q[4];
    if (!(ss >> e.file >> t[0] >> t[1] >> t[2] >> q[0] >> q[1] >> q[2] >> q[3]))
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": malformed bmesh line");
    const Eigen::Quaterniond quat(q[3], q[0], q[1], q[2]); // (w, x, y, z)
    if (!(quat.norm() > 0.5))
      throw std::runtime_error(path + ":" + std::to_string(line_no) + ": bad quaternion");
    e.pose.setIdentity();
    e.pose.topLeftCorner<3, 3>() = quat.normalized().toRotationMatrix().transpose();
    e.pose.topRightCorner<3, 1>() = Eigen::Vector3d(t[0], t[1], t[2]);
    out.push_back(e);
  }
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
  pcl::PointCloud<pcl::PointXYZ> grid;
  if (pcl::io::loadPLYFile(path, grid) < 0)
    throw std::runtime_error("cannot read PLY " + path);
  detail::RangeFilteredCloud finite(0.0, std::numeric_limits<double>::infinity());
  finite.reserve(grid.size());
  for (const auto& p : grid)
    finite.add(p.x, p.y, p.z);
  const pcl::PointCloud<pcl::PointXYZ>::Ptr out = finite.finish();
  if (out->empty())
    throw std::runtime_error("no finite points in " + path);
  return out;
}

} // namespace io
} // namespace pcl_parallel
