/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/io/atomic_write.h>
#include <pcl_parallel/io/g2o.h>
#include <pcl_parallel/io/pose_files.h> // kRigidMotionTolerance

#include <algorithm>
#include <charconv>
#include <cmath>
#include <ostream>
#include <stdexcept>

namespace pcl_parallel {
namespace io {

namespace {

[[noreturn]] void
refuse(const std::string& path, const std::string& what)
{
  throw std::invalid_argument("pcl_parallel::io::writeG2oSe2: " + path + ": " + what);
}

/** A pose g2o's SE2 can hold: finite, its rotation about z alone. */
void
requirePlanar(const std::string& path, const Eigen::Matrix4d& pose, const std::string& name)
{
  if (!pose.allFinite())
    refuse(path, name + " is not finite");
  const double tilt = std::max({std::abs(pose(2, 0)),
                                std::abs(pose(2, 1)),
                                std::abs(pose(0, 2)),
                                std::abs(pose(1, 2)),
                                std::abs(pose(2, 2) - 1.0)});
  if (tilt > kRigidMotionTolerance)
    refuse(path, name + " is not a rotation about z (a 3D pose has no SE(2) vertex)");
}

/** Shortest decimal form that reads back to the same double (as the pose files). */
void
writeNumber(std::ostream& out, double v)
{
  char buf[40];
  const auto res = std::to_chars(buf, buf + sizeof(buf), v);
  out << ' ';
  out.write(buf, res.ptr - buf);
}

} // namespace

Eigen::Vector3d
toSe2(const Eigen::Matrix4d& pose)
{
  return {pose(0, 3), pose(1, 3), std::atan2(pose(1, 0), pose(0, 0))};
}

G2oEdgeSe2
g2oEdgeBetween(const std::vector<Eigen::Matrix4d>& poses,
               std::size_t from,
               std::size_t to,
               const Eigen::Matrix3d& information)
{
  G2oEdgeSe2 edge;
  edge.from = from;
  edge.to = to;
  const Eigen::Matrix4d& a = poses.at(from);
  const Eigen::Matrix4d& b = poses.at(to);
  edge.measurement.topLeftCorner<3, 3>() =
      a.topLeftCorner<3, 3>().transpose() * b.topLeftCorner<3, 3>();
  edge.measurement.topRightCorner<3, 1>() =
      a.topLeftCorner<3, 3>().transpose() *
      (b.topRightCorner<3, 1>() - a.topRightCorner<3, 1>());
  edge.information = information;
  return edge;
}

void
writeG2oSe2(const std::string& path,
            const std::vector<Eigen::Matrix4d>& poses,
            const std::vector<G2oEdgeSe2>& edges)
{
  for (std::size_t i = 0; i < poses.size(); ++i)
    requirePlanar(path, poses[i], "pose " + std::to_string(i));
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const G2oEdgeSe2& e = edges[k];
    const std::string name = "edge " + std::to_string(k);
    if (e.from >= poses.size() || e.to >= poses.size())
      refuse(path, name + " joins a pose beyond the " + std::to_string(poses.size()));
    requirePlanar(path, e.measurement, name + "'s measurement");
    if (!e.information.allFinite() || !e.information.isApprox(e.information.transpose()))
      refuse(path, name + "'s information is not finite and symmetric");
  }
  writeStreamAtomically(path, [&](std::ostream& out) {
    for (std::size_t i = 0; i < poses.size(); ++i) {
      out << "VERTEX_SE2 " << i;
      for (const double v : toSe2(poses[i]))
        writeNumber(out, v);
      out << '\n';
    }
    for (const G2oEdgeSe2& e : edges) {
      out << "EDGE_SE2 " << e.from << ' ' << e.to;
      for (const double v : toSe2(e.measurement))
        writeNumber(out, v);
      for (int r = 0; r < 3; ++r) // g2o's upper triangle, row by row
        for (int c = r; c < 3; ++c)
          writeNumber(out, e.information(r, c));
      out << '\n';
    }
  });
}

} // namespace io
} // namespace pcl_parallel
