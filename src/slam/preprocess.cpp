/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/slam/preprocess.h>

#include <Eigen/Geometry>

#include <cstdint>

namespace pcl_parallel {
namespace slam {

Cloud::Ptr
cropRange(const Cloud& scan, double min_range, double max_range)
{
  Cloud::Ptr out(new Cloud);
  out->reserve(scan.size());
  const double lo = min_range * min_range, hi = max_range * max_range;
  for (const auto& p : scan) {
    if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)))
      continue;
    const double r2 = double(p.x) * p.x + double(p.y) * p.y + double(p.z) * p.z;
    if (r2 >= lo && r2 <= hi)
      out->push_back(p);
  }
  return out;
}

Pose
interpolateMotion(const Pose& motion, double s)
{
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(motion.topLeftCorner<3, 3>()));
  Pose out = Pose::Identity();
  out.topLeftCorner<3, 3>() = Eigen::AngleAxisd(s * aa.angle(), aa.axis()).toRotationMatrix();
  out.topRightCorner<3, 1>() = s * motion.topRightCorner<3, 1>();
  return out;
}

Pose
sweepMotion(const Pose& motion, double span, double sweep_period)
{
  if (sweep_period <= 0.0 || !(span > sweep_period))
    return motion;
  return interpolateMotion(motion, sweep_period / span);
}

Cloud::Ptr
deskew(const Cloud& scan, const Pose& motion, unsigned num_threads, bool clockwise)
{
  Cloud::Ptr out(new Cloud(scan));
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(motion.topLeftCorner<3, 3>()));
  const Eigen::Vector3d t = motion.topRightCorner<3, 1>();
  const std::int64_t n = static_cast<std::int64_t>(scan.size());
  const unsigned threads = resolveNumberOfThreads(num_threads);
#pragma omp parallel for num_threads(threads) schedule(static) if (threads > 1 && n > 20000)
  for (std::int64_t i = 0; i < n; ++i) {
    const PointT& p = scan[i];
    const double s = sweepTime(p, clockwise) - 0.5; // motion^s, s in [-1/2, 1/2]
    const Eigen::Vector3d q =
        Eigen::AngleAxisd(s * aa.angle(), aa.axis()) * p.getVector3fMap().cast<double>() +
        s * t;
    (*out)[i].getVector3fMap() = q.cast<float>();
  }
  return out;
}

} // namespace slam
} // namespace pcl_parallel
