/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/types.h>

#include <vector>

namespace pcl_parallel {
class KdTreeIndex;

namespace slam {

/**
 * \brief The scanner's path during one sweep: knot poses (world) at evenly spaced sweep
 * times 0, 1/K, ..., 1, at constant velocity between neighbouring knots (a screw motion).
 * A spinning LiDAR carried by hand turns faster and slower within one sweep; K pieces
 * follow that where one constant velocity (deskew) cannot (docs/design.md, "A sweep's
 * path").
 */
class SweepPath {
public:
  /** K = `pieces` pieces at the constant velocity of `sweep` (the motion over the whole
   *  sweep, scanner frame), the pose at mid-sweep `mid`. */
  SweepPath(const Pose& mid, const Pose& sweep, int pieces);

  /** The pose at sweep time t in [0, 1]. */
  Pose
  at(double t) const;
  /** The pose at mid-sweep. */
  Pose
  mid() const
  {
    return at(0.5);
  }
  /** The knots. */
  const Poses&
  knots() const
  {
    return knots_;
  }
  /** The knots, for the fit to move. */
  Poses&
  knots()
  {
    return knots_;
  }

private:
  Poses knots_;
};

/** The points of a scan, measured at sweep times `times` (one each, in [0, 1]), moved
 *  into the frame of the path's mid-sweep pose: p' = mid⁻¹ path(t) p. */
Cloud::Ptr
deskewAlong(const Cloud& scan,
            const std::vector<float>& times,
            const SweepPath& path,
            unsigned num_threads);

/** What holds a sweep path besides its points (fitSweepPath): a path bends where its
 *  points show it, and keeps its velocity where they leave it free (a piece that sees one
 *  wall). */
struct SweepPathPrior {
  double point_sigma = 0.01; ///< the points' residual spread [m]
  /** The spread of one piece's change of velocity (its second difference), rotation
   *  [rad] and translation [m]. */
  double bend_rotation = 0.003;
  double bend_translation = 0.003; ///< see bend_rotation

  /** The prior of a sweep of `seconds` in `pieces` pieces: bends of an angular and a
   *  linear acceleration of 0.2 rad/s² and 0.2 m/s² over a piece's time, dt² times those
   *  (docs/design.md, "A sweep's path"). */
  static SweepPathPrior
  forSweep(double seconds, int pieces);
};

/**
 * \brief Fits a sweep path to a map (point-to-plane, each point at its time's pose;
 * CT-ICP, Dellenbach et al. ICRA 2022, with K pieces instead of one): Gauss-Newton over
 * the knots, each point's pairs found anew every iteration within `gate`, a
 * Geman-McClure kernel of scale gate / 9 (as the matcher's), held by `prior`. The
 * normal equations are summed in fixed blocks in a fixed order: the same path for any
 * thread count. False when the system is singular or too few points pair.
 */
bool
fitSweepPath(SweepPath& path,
             const Cloud& scan,
             const std::vector<float>& times,
             const MapCloud& map,
             const KdTreeIndex& map_index,
             double gate,
             const SweepPathPrior& prior,
             int max_iterations,
             unsigned num_threads);

} // namespace slam
} // namespace pcl_parallel
