/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/types.h>

#include <cstddef>

namespace pcl_parallel {
namespace slam {

/** Fraction of (every step-th point of) `source`, moved by `pose`, that has a point of
 *  `target` within max_distance: how much of one scan another sees (3DTK's minimum
 *  overlap). Loop links are kept by it, and the front end's pose search decides by it
 *  when to search and which candidate wins. 0 for an empty source. */
double
overlap(const Cloud& source,
        const Pose& pose,
        const KdTreeIndex& target,
        double max_distance,
        std::size_t step = 1);

} // namespace slam
} // namespace pcl_parallel
