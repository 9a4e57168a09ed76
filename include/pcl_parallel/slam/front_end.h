/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/types.h>

#include <Eigen/Core>

namespace pcl_parallel {
namespace slam {

/** How a scan is matched: against its predecessor (the paper's sequential pICP, Sec. II)
 *  or against the local map of the recent scans (3DTK's metascan, KISS-ICP). */
enum class MatchTarget { kPreviousScan, kLocalMap };

/** The front end's settings; lengths in the scans' units (metres for the defaults). */
struct FrontEndParameters {
  MatchTarget target = MatchTarget::kLocalMap;
  double voxel_size = 0.1; ///< scan reduction kept in the map and for loop closing
  /** Coarser sample of the registered points: per voxel the measured point nearest its
   *  centroid (filters::voxelNearestToCentroid), so they lie on the surfaces. */
  double source_voxel_size = 0.3;
  double map_distance = 30.0;               ///< local map: voxels within this of the scanner
  double map_voxel_size = 0.3;              ///< local map voxel
  int map_points_per_voxel = 20;            ///< local map density
  double max_correspondence_distance = 0.5; ///< pICP gate (adaptive: its first value and cap)
  /** A match whose gate is wider than this is refined from its result within this gate
   *  (coarse to fine): the wide gate is the prediction's basin, the narrow one keeps
   *  pairs across occlusion edges and unseen surfaces out of the final pose. With
   *  point-to-plane, never below 9x the wide match's residual RMS, so the kernel
   *  (gate / 9) keeps the inliers (docs/design.md, "Coarse to fine"). 0: no refinement. */
  double final_correspondence_distance = 0.2; ///< 2 voxels, as the pipeline's default
  /** KISS-ICP's adaptive gate (Vizzo et al. 2023, Sec. III-C): 3 sigma of how far the
   *  matches moved the scans from the motion prior, Geman-McClure kernel of scale
   *  sigma / 3. Off: the fixed gate and no kernel. */
  bool adaptive_threshold = true;
  /** With the adaptive threshold: the motion prior (odometry step or constant velocity)
   *  enters pICP as a Gaussian prior (ParallelIterativeClosestPoint::setMotionPrior), so
   *  directions a sparse or one-sided scan leaves unconstrained stay at the prediction
   *  (docs/design.md, "Real data"). Its spread: the RMS of how far the matches moved the
   *  scans from the prediction, in translation and in rotation each, once 20 such
   *  deviations are in; before, the threshold's sigma ("The motion prior's spread"). */
  bool motion_prior = true;
  /** Local map without odometry: the map match starts from a match to the previous scan
   *  (from constant velocity), not from constant velocity itself. Where the motion
   *  changes more between scans than the map's basin allows (keyframes metres apart, a
   *  car pulling away, a handheld scanner swung), a map match from a poor guess can slide
   *  into the copy of the scene that earlier wrong poses left in the map, and that error
   *  reinforces itself; a single previous scan holds no such copy (docs/design.md,
   *  "Real data"). Ignored with odometry, whose step is the guess. */
  bool guess_from_previous_scan = true;
  /** Without odometry, the match to the previous scan (the map match's guess, or with
   *  kPreviousScan the match itself) also starts from the prediction moved
   *  along the direction of travel by -2, -1, +1 and +2 sigma of the adaptive gate (none
   *  behind the previous scan's position: speed, not direction), and
   *  the start whose match fits the previous scan best (pICP's fitness, pairs within
   *  sqrt(gate): metres assumed, docs/design.md "Speed hypotheses")
   *  gives the guess. Constant velocity misses a change of speed (a car pulling away
   *  between keyframes 0.5 s apart, 5-8 m), and along a street a start metres short
   *  converges to a false fit near the previous pose, which then sets the velocity
   *  (docs/design.md, "Speed hypotheses"). Starts within the refinement gate of the
   *  prediction are not tried, so a narrow gate costs nothing. A match that ends where
   *  the previous scan was taken shares its sampling pattern and does not replace one
   *  that moves (docs/design.md, "Standing still"). */
  bool speed_hypotheses = true;
  /** Without odometry, where the match to the previous scan looks wrong (the first one,
   *  one where a turn hypothesis won, or one that overlaps the previous scan less than
   *  0.7 times the recent matches' median), the pose is also searched over all headings
   *  about `up` and translations (correlativeSearch), and pICP from its best candidates
   *  gives the guess where one overlaps the previous scan more (docs/design.md, "Pose
   *  search"). For motion nothing predicts: a stop-and-go scanner without initial poses
   *  is carried from one station to the next and turned by any angle. */
  bool pose_search = true;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ(); ///< the vertical axis, scanner frame
  /** Point-to-plane pICP instead of point-to-point. */
  bool point_to_plane = true;
  /** Point-to-plane normals: false (default) estimates them once per scan from its
   *  reduced points and carries them in the map (fast; right for scanners that
   *  sample surfaces densely in one scan: spinning, tilting, terrestrial); true estimates
   *  them on the local map after each refresh (slower on large maps; better for sparse,
   *  non-repetitive patterns such as solid-state LiDARs'). */
  bool normals_from_map = false;
  int max_iterations = 50;
  double transformation_epsilon = 1e-8; ///< pICP stop: squared change of the transform
  /** Deskew scans of a spinning LiDAR (sweep time from azimuth, see sweepTime) with the
   *  predicted motion; off for stop-and-go scanners. */
  bool deskew = false;
  /** Seconds one sweep takes (0.1 for a 10 Hz LiDAR). With deskew and the scans' time
   *  stamps, a scan is deskewed by one sweep's share of the predicted step (sweepMotion),
   *  so keyframes taken seconds apart are not deskewed by the whole step between them.
   *  0: each scan is the sweep after the previous one, deskewed by the whole step. */
  double sweep_period = 0.0;
  /** The head turns clockwise seen from +z in the scans' frame (KITTI's Velodyne), from
   *  facing backwards; false: counter-clockwise (see sweepTime). */
  bool sweep_clockwise = true;
  unsigned num_threads = 0;
};

} // namespace slam
} // namespace pcl_parallel
