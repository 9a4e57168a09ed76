/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/slam/overlap.h>

#include <limits>

namespace pcl_parallel {
namespace slam {

namespace {

/** Of every step-th source point moved by `pose`: how many were tried, how many have a
 *  target point within max_distance, and the sum of those squared distances. */
struct Pairs {
  std::size_t tried = 0, hits = 0;
  double sum_sqr = 0.0;
};

Pairs
nearestPairs(const Cloud& source,
             const Pose& pose,
             const KdTreeIndex& target,
             double max_distance,
             std::size_t step)
{
  const Eigen::Matrix3f r = pose.topLeftCorner<3, 3>().cast<float>();
  const Eigen::Vector3f t = pose.topRightCorner<3, 1>().cast<float>();
  const float max_sqr = static_cast<float>(max_distance * max_distance);
  Pairs p;
  for (std::size_t k = 0; k < source.size(); k += step) {
    const Eigen::Vector3f q = r * source[k].getVector3fMap() + t;
    float d2;
    ++p.tried;
    if (target.nearest(q.data(), max_sqr, d2) != KdTreeIndex::kInvalid) {
      ++p.hits;
      p.sum_sqr += d2;
    }
  }
  return p;
}

} // namespace

double
overlap(const Cloud& source,
        const Pose& pose,
        const KdTreeIndex& target,
        double max_distance,
        std::size_t step)
{
  const Pairs p = nearestPairs(source, pose, target, max_distance, step);
  return p.tried ? static_cast<double>(p.hits) / static_cast<double>(p.tried) : 0.0;
}

double
fitnessScore(const Cloud& source,
             const Pose& pose,
             const KdTreeIndex& target,
             double max_distance)
{
  const Pairs p = nearestPairs(source, pose, target, max_distance, 1);
  return p.hits ? p.sum_sqr / static_cast<double>(p.hits) : std::numeric_limits<double>::max();
}

} // namespace slam
} // namespace pcl_parallel
