/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * One scan's record as it passes the pipeline's stages (slam/pipeline.h): each stage
 * fills its part, the pose graph takes it, and its report stays with the pipeline.
 */
#pragma once

#include <pcl_parallel/slam/loop_closure.h>
#include <pcl_parallel/slam/types.h>

#include <cstddef>
#include <limits>
#include <memory>
#include <vector>

namespace pcl_parallel {
namespace slam {

/** A scan deskewed and reduced (Reducer), with its tree and normals once described. */
struct ReducedScan {
  Cloud::Ptr reduced; ///< deskewed, reduced at voxel_size, scanner frame
  /** The reduced points' normals (scanner frame, from their 10 nearest reduced points),
   *  zero where a neighbourhood is no plane: pLUM takes them (LoopCloser::addScan). */
  std::vector<Eigen::Vector3f> normals;
  /** The reduced points' k-d tree (scanner frame): built once, for the normals, the next
   *  scan's match to this one and pLUM (LoopCloser::addScan). */
  std::shared_ptr<const KdTreeIndex> tree;
};

/** What happened to one scan: the figures a run reports. */
struct ScanReport {
  std::size_t points = 0;         ///< read
  std::size_t reduced_points = 0; ///< kept (after crop, deskew and reduction)
  std::size_t source_points = 0;  ///< registered against the map
  bool converged = true;          ///< pICP; false: the prediction was kept
  double fitness = 0.0;           ///< pICP's mean squared pair distance, within the gate
  double gate = 0.0;              ///< pICP's correspondence distance (adaptive)
  /** How far pICP moved the scan from the motion prior (translation plus rotation at the
   *  median range, as the adaptive gate measures it). */
  double correction = 0.0;
  /** How far the motion prior moved the scan from the previous one (measured alike): with
   *  odometry, the odometry's step. */
  double predicted_step = 0.0;
  /** Where the winning start of the speed hypotheses lay along the direction of travel,
   *  from the prediction (scan units; 0: the prediction's, or none tried). */
  double start_offset = 0.0;
  /** The winning turn-rate hypothesis: the predicted turn scaled by 1 + start_turn (-1:
   *  stopped, 1: doubled; 0: the prediction's, or none tried). */
  double start_turn = 0.0;
  bool pose_searched = false; ///< the pose search ran (PoseGuessParameters::pose_search)
  /** With deskewing: the scan was deskewed again by its matched step, which differed
   *  from the predicted one (a turn begun or ended), and matched again. */
  bool deskewed_again = false;
  /** The pose search's winning start, turned about `up` from the previous scan's
   *  heading (rad); NaN: no search ran, or the prediction's match won. */
  double start_heading = std::numeric_limits<double>::quiet_NaN();
  /** How many scans the match was made against, in effect: (sum n_s)^2 / sum n_s^2 over
   *  the scans s that hold the nearest map points of the matched source points (1: the
   *  previous scan, or one scan held them all). docs/design.md, "Sequence constraints". */
  double map_scans = 1.0;
  double seconds = 0.0;             ///< all stages for this scan
  std::vector<LoopCandidate> loops; ///< loop pairs tried
  int lum_iterations = 0;           ///< pLUM run after this scan (0: none)
  /** After Pipeline::finish(): LoopCloser::sequenceChi2() of this scan (-1: none). */
  double sequence_chi2 = -1.0;
};

/** A scan after the front end's stages (Pipeline::track), as the pose graph takes it
 *  (Pipeline::addTracked, Pipeline::addMatched). */
struct ScanRecord {
  std::size_t index = 0;              ///< in the sequence
  Pose prediction = Pose::Identity(); ///< where the motion model put it (world)
  Pose pose = Pose::Identity();       ///< matched (world); the prediction where pICP failed
  /** Its pose relative to the previous scan's, as the front end matched it (the first
   *  scan's: its pose). */
  Pose step = Pose::Identity();
  ReducedScan scan; ///< deskewed and reduced, with its tree and normals
  /** The match's information (point-to-plane: pICP's final Hessian over its residual
   *  variance, without the motion prior): how well the pose relative to the map, or to
   *  the previous scan, is known. Zero when pICP did not run or failed. */
  Information information = Information::Zero();
  double information_pairs = 0.0; ///< ... from this many pairs (sum of robust weights)
  /** What the stages report about the scan. */
  ScanReport report;
};

} // namespace slam
} // namespace pcl_parallel
