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
  int headings = 72; ///< headings of the coarse search (5 degrees)
  /** > 0: only headings within this many radians either side of the source's own (a
   *  window about a predicted pose); 0: the whole circle. */
  double max_turn = 0.0;
  /** Points of either scan this far from the origin horizontally are scored; 0: twice the
   *  radius (two scans whose origins lie within the radius meet within it). */
  double reach = 0.0;
  std::size_t max_points = 500; ///< the source's points scored, at most (every k-th)
  std::size_t candidates = 3;   ///< distinct poses returned, at most
  /** Threads (0: all cores). */
  unsigned num_threads = 0;
};

/**
 * \brief Correlative scan matching (Olson, "Real-time correlative scan matching", ICRA
 * 2009) about a vertical axis: the poses of `source` in `target`'s frame, turned about
 * `up` and moved across it, at which the source's points fall nearest the target's,
 * best first. Scored on a likelihood field of the target's points (2 in a point's cell,
 * 1 in the cells around it, 0 elsewhere): a coarse search (2 cells, every
 * 360/headings degrees) over all translations within the radius, at the source's own
 * heights, then a fine one (1 cell, a quarter of the heading step, heights within 2
 * cells) around the 16 best distinct coarse peaks. For scans whose relative pose nothing
 * predicts (a stop-and-go scanner without initial poses): the candidates start pICP,
 * which also takes what the search leaves (tilt: the scanners are assumed level). Same
 * result for any thread count. Empty if either scan has no points within reach.
 * With max_turn, a window about the source's pose as given (loop closing: the target
 * moved into the source's predicted frame). Throws std::invalid_argument for cell <= 0
 * or not finite, headings < 1, a negative or non-finite radius, max_turn or reach,
 * max_points 0, or a zero `up`.
 */
std::vector<Pose>
correlativeSearch(const Cloud& source,
                  const Cloud& target,
                  const Eigen::Vector3d& up,
                  const CorrelativeSearchParameters& params = CorrelativeSearchParameters());

} // namespace slam
} // namespace pcl_parallel
