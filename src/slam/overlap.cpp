/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/slam/overlap.h>

namespace pcl_parallel {
namespace slam {

double
overlap(const Cloud& source,
        const Pose& pose,
        const KdTreeIndex& target,
        double max_distance,
        std::size_t step)
{
  const Eigen::Matrix3f r = pose.topLeftCorner<3, 3>().cast<float>();
  const Eigen::Vector3f t = pose.topRightCorner<3, 1>().cast<float>();
  const float max_sqr = static_cast<float>(max_distance * max_distance);
  std::size_t tried = 0, hits = 0;
  for (std::size_t k = 0; k < source.size(); k += step) {
    const Eigen::Vector3f q = r * source[k].getVector3fMap() + t;
    float d2;
    ++tried;
    hits += target.nearest(q.data(), max_sqr, d2) != KdTreeIndex::kInvalid ? 1 : 0;
  }
  return tried ? static_cast<double>(hits) / static_cast<double>(tried) : 0.0;
}

} // namespace slam
} // namespace pcl_parallel
