/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/slam/overlap.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace pcl_parallel {
namespace slam {

double
overlap(const Cloud& source, const Pose& pose, const KdTreeIndex& target, double max_distance)
{
  const Eigen::Matrix3f r = pose.topLeftCorner<3, 3>().cast<float>();
  const Eigen::Vector3f t = pose.topRightCorner<3, 1>().cast<float>();
  const float max_sqr = static_cast<float>(max_distance * max_distance);
  std::size_t hits = 0;
  for (const auto& p : source) {
    const Eigen::Vector3f q = r * p.getVector3fMap() + t;
    float d2;
    hits += target.nearest(q.data(), max_sqr, d2) != KdTreeIndex::kInvalid ? 1 : 0;
  }
  return source.empty() ? 0.0 : static_cast<double>(hits) / static_cast<double>(source.size());
}

FreeSpace::FreeSpace(const Cloud& scan, const Eigen::Vector3d& up, double bin)
{
  if (!(bin >= kMinBin) || !std::isfinite(bin) || !(up.norm() > 0.0) || !up.allFinite())
    throw std::invalid_argument("FreeSpace: a bin of at least 0.001 rad and a non-zero, "
                                "finite up axis needed");
  up_ = up.normalized();
  u_ = up_.unitOrthogonal();
  v_ = up_.cross(u_);
  azimuths_ = static_cast<int>(std::ceil(2.0 * M_PI / bin));
  elevations_ = static_cast<int>(std::ceil(M_PI / bin));
  nearest_.assign(static_cast<std::size_t>(azimuths_) * elevations_,
                  std::numeric_limits<float>::infinity());
  for (const auto& point : scan) {
    double range;
    if (const long b = binOf(point.getVector3fMap().cast<double>(), range); b >= 0)
      nearest_[b] = std::min(nearest_[b], static_cast<float>(range));
  }
  seenAround();
}

void
FreeSpace::seenAround()
{
  // A wall seen at a grazing angle spans far more range within one bin than the reduced
  // points in it show; the nearest of the neighbouring bins bounds what was seen through.
  std::vector<float> seen = nearest_;
  for (int a = 0; a < azimuths_; ++a)
    for (int e = 0; e < elevations_; ++e) {
      float& s = seen[static_cast<std::size_t>(a) * elevations_ + e];
      if (!std::isfinite(s)) // not seen: stays so
        continue;
      for (int da = -1; da <= 1; ++da)
        for (int de = std::max(-e, -1); de <= 1 && e + de < elevations_; ++de) {
          const int n = (a + da + azimuths_) % azimuths_; // azimuth wraps around
          s = std::min(s, nearest_[static_cast<std::size_t>(n) * elevations_ + e + de]);
        }
    }
  nearest_.swap(seen);
}

long
FreeSpace::binOf(const Eigen::Vector3d& p, double& range) const
{
  range = p.norm();
  if (!(range > 0.0) || !std::isfinite(range))
    return -1;
  const double azimuth = std::atan2(p.dot(v_), p.dot(u_)) + M_PI; // [0, 2 pi]
  const double elevation = std::asin(std::clamp(p.dot(up_) / range, -1.0, 1.0)) + M_PI / 2;
  const int a = std::min(azimuths_ - 1, static_cast<int>(azimuth / (2.0 * M_PI) * azimuths_));
  const int e = std::min(elevations_ - 1, static_cast<int>(elevation / M_PI * elevations_));
  return static_cast<long>(a) * elevations_ + e;
}

double
FreeSpace::conflicts(const Cloud& source, const Pose& pose, double margin) const
{
  if (!(margin >= 0.0))
    throw std::invalid_argument("FreeSpace::conflicts: margin >= 0 needed");
  const Eigen::Matrix3d r = pose.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = pose.topRightCorner<3, 1>();
  std::size_t in_front = 0;
  for (const auto& point : source) {
    double range;
    const long b = binOf(r * point.getVector3fMap().cast<double>() + t, range);
    // An empty bin (+inf) was not seen: no conflict there.
    in_front += b >= 0 && std::isfinite(nearest_[b]) && range < nearest_[b] - margin ? 1 : 0;
  }
  return source.empty() ? 0.0 : static_cast<double>(in_front) / source.size();
}

double
mutualConflicts(const Cloud& a,
                const Cloud& b,
                const Pose& b_in_a,
                const Eigen::Vector3d& up,
                double margin)
{
  return std::max(FreeSpace(a, up).conflicts(b, b_in_a, margin),
                  FreeSpace(b, up).conflicts(a, b_in_a.inverse(), margin));
}

} // namespace slam
} // namespace pcl_parallel
