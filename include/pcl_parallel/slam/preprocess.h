/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Per-scan preprocessing before matching: range crop and deskewing.
 */
#pragma once

#include <pcl_parallel/slam/types.h>

#include <cmath>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace slam {

/** The finite points whose distance from the scanner lies in [min_range, max_range];
 *  never a point at the scanner's origin, which drivers write for a beam without a return
 *  (Ouster's organised clouds: often more than half the points, which would make the
 *  median range, and every length derived from it, zero). */
Cloud::Ptr
cropRange(const Cloud& scan, double min_range, double max_range, unsigned num_threads = 0);
/** ... and the times of the points kept (`times`: one per point of `scan`). */
Cloud::Ptr
cropRange(const Cloud& scan,
          double min_range,
          double max_range,
          const std::vector<float>& times,
          std::vector<float>& kept_times,
          unsigned num_threads = 0);

/** The median of `values` (the upper one of an even count: the size/2-th smallest);
 *  `values` must not be empty. */
double
median(std::vector<double> values);

/** Median distance of the finite points from the scanner (0 for an empty scan). */
double
medianRange(const Cloud& scan);

/** Throws std::invalid_argument "`context`: N point times for M points" unless `times`
 *  (a count of per-point times) is one per point of `scan`. */
void
requireOnePerPoint(const Cloud& scan, std::size_t times, const std::string& context);

/** Throws std::invalid_argument naming scan `index` when its cropped points are none
 *  (cropRange left no finite point in range, away from the origin). */
void
requirePointsInRange(const Cloud& cropped, std::size_t index);

/** Throws std::invalid_argument naming `context` unless `scan` (finite points) can be in
 *  its scanner's own frame: the pipeline takes the origin as the scanner (ranges,
 *  deskewing, the lengths it derives from the median range). A scan whose centroid lies
 *  more than 100 times its RMS spread from the origin was written in another frame (a
 *  georeferenced or pre-registered scan; at UTM coordinates float keeps decimetres).
 *  Scans whose points all coincide are not judged. */
void
requireScannerFrame(const Cloud& scan, const std::string& context, unsigned num_threads = 0);

/** Per-point times in any unit and origin (a driver's time field: ns, s, absolute s) as
 *  fractions of the sweep, 0 at the earliest and 1 at the latest point (as KISS-ICP
 *  normalises per-point timestamps). All equal: 0.5 each, the sweep's middle, which
 *  deskewing leaves where it is. Throws std::invalid_argument for a time that is not
 *  finite. */
std::vector<float>
sweepFractions(const std::vector<double>& times);

/** True when per-point times span a sweep: at least two different values. Times all
 *  equal (a driver that leaves its time field zero) say nothing of when a point was
 *  measured. */
bool
spansSweep(const std::vector<double>& times);

/** The sweep fractions deskewing goes by: sweepFractions(times) where they span a sweep
 *  (spansSweep), else none (by azimuth). */
std::vector<float>
sweepTimes(const std::vector<double>& times);

/** Time of a point within its sweep, in [0, 1], for a spinning LiDAR that starts facing
 *  backwards (-x) and turns clockwise seen from +z (KITTI's Velodyne; KISS-ICP derives
 *  KITTI's timestamps the same way): t = (1 - atan2(y, x) / pi) / 2, 0.5 facing forwards;
 *  counter-clockwise: 1 - t. */
inline double
sweepTime(const Eigen::Vector3d& p, bool clockwise = true)
{
  const double a = std::atan2(p.y(), p.x()) / M_PI;
  return 0.5 * (clockwise ? 1.0 - a : 1.0 + a);
}
/** sweepTime of a point of a cloud. */
inline double
sweepTime(const PointT& p, bool clockwise = true)
{
  return sweepTime(p.getVector3fMap().cast<double>().eval(), clockwise);
}

/** Pose at fraction s of a relative motion at constant velocity: motion^s = exp(s log
 *  motion) in SE(3), a screw motion (a vehicle turning at a steady rate follows a circular
 *  arc, not the chord; KISS-ICP deskews with Sophus' SE3::exp the same way). s = 1: the
 *  motion; s = -1: its inverse. */
Pose
interpolateMotion(const Pose& motion, double s);

/** The motion over `span` seconds at the velocity the scanner has at the end of `step`
 *  (taken over `span`), given the step before it (over `previous_span`): each step's
 *  velocity is that of its middle, so their difference, carried on from the middle to the
 *  end (constant acceleration), gives the velocity at the end. Deskewing a sweep at the
 *  end of a step by the step's own velocity lags half a step behind a turn. Spans of 0
 *  (times unknown): steps of equal time. */
Pose
extrapolateMotion(const Pose& step, double span, const Pose& previous, double previous_span);

/** The motion during one sweep, at the constant velocity of `motion` taken over `span`
 *  seconds: motion^(sweep_period / span), at most the whole motion. A keyframe several
 *  sweeps after its predecessor is skewed by one sweep's motion, not by the whole step.
 *  sweep_period 0: the whole motion (consecutive sweeps). */
Pose
sweepMotion(const Pose& motion, double span, double sweep_period);

/** The motion during sweep k of a mapped sequence, for deskewing the scan at its pose in
 *  `poses` (the map pass): the velocity at scan k from both neighbours, (poses[k-1]^-1
 *  poses[k+1])^(1/2), where the front end, matching as the scans came, had only the steps
 *  before it; one-sided at the ends. With sweep_period > 0 and `stamps` (one per pose),
 *  one sweep's share of it (sweepMotion). Identity for fewer than two poses; throws
 *  std::out_of_range for k past the poses. */
Pose
sweepMotionAt(const Poses& poses,
              const std::vector<double>& stamps,
              std::size_t k,
              double sweep_period);

/**
 * \brief Removes the skew of a scan taken while moving (KISS-ICP's deskewing, Vizzo et
 * al. 2023, Sec. III-A): each point, measured in the scanner frame at its sweep time t,
 * is moved into the frame at mid-sweep, assuming the scanner moved by `motion` (the
 * relative pose from one mid-sweep to the next) at constant velocity over the sweep:
 * p' = motion^(t - 1/2) p, t = sweepTime(p, clockwise). Parallel; the result is the same for
 * any thread count.
 */
Cloud::Ptr
deskew(const Cloud& scan, const Pose& motion, unsigned num_threads = 0, bool clockwise = true);
/** ... with each point's sweep time t from `sweep_times` (sweepFractions, one per point)
 *  instead of its azimuth: any scan pattern (a solid-state LiDAR's, a head turning either
 *  way) with per-point times. Throws std::invalid_argument for a size other than the
 *  scan's. */
Cloud::Ptr
deskew(const Cloud& scan,
       const std::vector<float>& sweep_times,
       const Pose& motion,
       unsigned num_threads = 0);
/** Points deskewed by `from` by their azimuths, deskewed by `to` instead, for a sample of a
 *  scan whose raw points are gone: each point q's measured time t is the fixed point of
 *  t = sweepTime(from^-(t - 1/2) q), found from q's own azimuth, or from the sweep's seam
 *  where the deskewing carried q across it, to a thousandth of a sweep; q moves by
 *  from^-(t - 1/2), then by to^(t - 1/2). Exact to that tolerance but near the vertical
 *  axis, where the deskewing's translation leaves a point no azimuth of its own. */
Cloud::Ptr
redeskew(const Cloud& deskewed,
         const Pose& from,
         const Pose& to,
         bool clockwise = true,
         unsigned num_threads = 0);
/** deskew by `sweep_times` where given, else (empty) by each point's azimuth, turning
 *  `clockwise` or not: how the pipeline deskews a scan, with its points' times where they
 *  span a sweep (spansSweep, sweepFractions). */
Cloud::Ptr
deskewSweep(const Cloud& scan,
            const std::vector<float>& sweep_times,
            const Pose& motion,
            bool clockwise,
            unsigned num_threads = 0);

} // namespace slam
} // namespace pcl_parallel
