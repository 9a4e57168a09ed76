/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * A 2D run's pose graph as the SE(2) graph that g2o and other planar SLAM back ends read
 * (io::writeG2oSe2): each of the run's links measured again by planar pICP.
 */
#pragma once

#include <pcl_parallel/io/g2o.h>
#include <pcl_parallel/slam/mapping.h>

#include <vector>

namespace pcl_parallel {
namespace io {
struct ScanDirectory;
}
namespace slam {

/** An edge per link of `result` (result.links; from the older scan to the newer): the
 *  relative pose planar pICP finds between the two scans, reduced as the pipeline reduced
 *  them, from their final relative pose within pLUM's final pair distance; its
 *  information the (x, y, yaw) block of pICP's Hessian over the residual variance (zero
 *  where the match found no pairs). For the vertices, the final poses. Throws
 *  std::invalid_argument for a run that was not planar (Parameters::planar). */
std::vector<io::G2oEdgeSe2>
measureLinksSe2(const io::ScanDirectory& scans, const MappingResult& result);

} // namespace slam
} // namespace pcl_parallel
