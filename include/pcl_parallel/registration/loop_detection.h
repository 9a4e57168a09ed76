/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <utility>
#include <vector>

namespace pcl_parallel {

/**
 * \brief Links of the pose graph by the paper's distance criterion (Sec. VI-C, as
 * slam6D's -cldist / -loopsize): consecutive scans (i, i+1), plus every pair (i, j) with
 * j - i >= loopsize whose positions (translations of the poses) are closer than cldist.
 *
 * Pairs are returned as (i, j) with i < j, sorted. loopsize < 2 is treated as 2 (pairs
 * of consecutive scans are already linked); cldist <= 0 gives the chain only.
 */
std::vector<std::pair<std::uint32_t, std::uint32_t>>
detectLinksByDistance(const std::vector<Eigen::Matrix4d>& poses, double cldist, int loopsize);

} // namespace pcl_parallel
