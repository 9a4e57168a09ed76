/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/types.h>

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace pcl_parallel {
namespace slam {

/** Settings of correlativeSearch; lengths in the scans' units. */
struct CorrelativeSearchParameters {
  double cell = 0.2; ///< grid cell of the fine search (the pipeline: 2 voxels)
  /** Translations are searched this far from the target's origin (at most 256 cells);
   *  0: as far as the target's points reach (their 90th percentile horizontal range). */
  double radius = 0.0;
  int headings = 72;            ///< headings of the coarse search (5 degrees)
  std::size_t max_points = 500; ///< the source's columns used, at most
  std::size_t candidates = 3;   ///< distinct poses returned, at most
  unsigned num_threads = 0;
};

/**
 * \brief Planar correlative scan matching (Olson, "Real-time correlative scan matching",
 * ICRA 2009): the poses of `source` in `target`'s frame, turned about `up` and moved
 * across it, at which most of the source's vertical structure (walls, trunks, poles:
 * grid columns whose points span at least two cells in height) falls on the target's,
 * best first. A coarse search (4 cells, every 360/headings degrees) over all
 * translations within the radius, then a fine one (1 cell, a quarter of the heading
 * step) around its best peaks. For scans with no prediction at all (a stop-and-go
 * scanner without initial poses): the result starts pICP. The scanners are assumed
 * level (tilt between the two scans well below a cell over the range). Same result
 * for any thread count. Empty if either scan has no vertical structure.
 */
std::vector<Pose>
correlativeSearch(const Cloud& source,
                  const Cloud& target,
                  const Eigen::Vector3d& up,
                  const CorrelativeSearchParameters& params = CorrelativeSearchParameters());

} // namespace slam
} // namespace pcl_parallel
