/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/evaluation/alignment.h>
#include <pcl_parallel/evaluation/pose_error.h>

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

/* Trajectory errors as the tools people compare against compute them (formulas and sources
 * in docs/design.md, "Evaluation"). Every function takes the estimate and the reference
 * (ground truth) as equally long pose lists, pose i of one belonging to pose i of the other
 * (associate() pairs them up first), p_world = T·p; lengths in the poses' unit (metres). */

namespace pcl_parallel {
namespace evaluation {

/** Absolute trajectory error (evo_ape): the estimate aligned to the reference (see
 *  Alignment), then per pose the distance between the positions (evo's translation_part)
 *  and the angle of est⁻¹·ref (evo's rotation_angle_deg). */
struct AbsoluteError {
  /** The alignment applied before the errors were taken. */
  Alignment alignment = Alignment::None;
  Similarity similarity;  ///< est -> reference frame (identity for Alignment::None)
  Statistics translation; ///< metres
  /** Statistics of the rotation errors in degrees. */
  Statistics rotation_deg;
};

/** ATE of \a estimate against \a reference (paired index by index) after \a alignment, as
 *  evo_ape. */
AbsoluteError
absoluteTrajectoryError(const Poses& estimate, const Poses& reference, Alignment alignment);

/** One segment of the KITTI odometry devkit (evaluate_odometry.cpp, calcSequenceErrors):
 *  from first_frame to the first frame whose distance along the reference path exceeds
 *  first_frame's by more than length; errors of the relative motion divided by the length. */
struct KittiSegment {
  /** The segment's first and last frame. */
  ///@{
  std::size_t first_frame = 0, last_frame = 0;
  ///@}
  /** The segment's path length on the reference (m). */
  double length = 0.0;
  double translation = 0.0; ///< |t(E)| / length (a fraction; the devkit prints it x100 as %)
  double rotation = 0.0;    ///< angle(E) / length, rad/m
};

/** The devkit's errors per length (its plot files, kept when at least 3 segments) and over
 *  all segments (its stats.txt and leaderboard numbers). */
struct KittiLengthError {
  /** The segment length (m) these errors are for. */
  double length = 0.0;
  /** Number of segments of this length. */
  std::size_t segments = 0;
  /** Mean translation error (% of the length) and rotation error (deg/m) over the segments. */
  ///@{
  double translation_percent = 0.0, rotation_deg_per_m = 0.0;
  ///@}
};

/** KITTI odometry devkit's relative error over segments of fixed path lengths. */
struct KittiRelativeError {
  std::vector<double> lengths; ///< segment lengths used
  std::size_t step = 10;       ///< first frames 0, step, 2 step, ...
  /** Every segment evaluated. */
  std::vector<KittiSegment> segments;
  std::vector<KittiLengthError> per_length; ///< one entry per length, even with 0 segments
  ///@{
  /** Means over all segments; zero (and valid() false) when no segment fits the path. */
  double translation_percent = 0.0, rotation_deg_per_m = 0.0;
  ///@}

  /** True when at least one segment was evaluated. */
  bool
  valid() const
  {
    return !segments.empty();
  }
};

/** The devkit's lengths, 100, 200, ..., 800 m. */
std::vector<double>
kittiDefaultLengths();

/** Lengths for a reference path of any length: the devkit's when the path is longer than
 *  800 m (so that each length fits at least once), else 8 lengths at 10%, 20%, ..., 80% of
 *  the path's length (the devkit's proportions for a path a little over 1 km), so short
 *  indoor and simulated runs get segments too. Empty for a path of zero length. */
std::vector<double>
kittiLengthsFor(const Poses& reference);

/** The KITTI devkit's relative error (same segments, same error, same averaging; in double
 *  where the devkit uses float). Empty lengths: kittiLengthsFor(reference). */
KittiRelativeError
kittiRelativeError(const Poses& estimate,
                   const Poses& reference,
                   std::vector<double> lengths = {},
                   std::size_t step = 10);

/** evo_rpe with --delta N --delta_unit f (consecutive pairs (0, N), (N, 2N), ...): per pair
 *  E = (ref_i⁻¹ ref_j)⁻¹ (est_i⁻¹ est_j); translation = |t(E)| (translation_part), rotation =
 *  angle(E) in degrees (angle_deg), point distance = | |ref_i - ref_j| - |est_i - est_j| |
 *  (point_distance). */
struct FrameRelativeError {
  /** Frames between the two poses of a pair. */
  std::size_t delta = 1;
  Statistics translation; ///< metres
  /** Statistics of the relative rotation errors in degrees. */
  Statistics rotation_deg;
  Statistics point_distance; ///< metres
};

/** Per-frame RPE of \a estimate against \a reference over pairs \a delta frames apart, as
 *  evo_rpe. */
FrameRelativeError
frameRelativeError(const Poses& estimate, const Poses& reference, std::size_t delta = 1);

/** evo's timestamp association (sync.matching_time_indices, as associate_trajectories
 *  calls it): for each stamp of the shorter list, the nearest stamp of the longer one, kept
 *  when at most max_diff apart. Returns (estimate index, reference index) pairs in the
 *  shorter list's order. */
std::vector<std::pair<std::size_t, std::size_t>>
associateByTimestamp(const std::vector<double>& estimate_stamps,
                     const std::vector<double>& reference_stamps,
                     double max_diff = 0.01);

/** Everything `pcl_pslam evaluate` reports, for two associated pose lists. */
struct EvaluationOptions {
  /** Alignment before the ATE. */
  Alignment alignment = Alignment::SE3;
  std::vector<double> kitti_lengths; ///< empty: kittiLengthsFor(reference)
  /** KITTI RPE: frames between segment starts (the devkit's 10). */
  std::size_t kitti_step = 10;
  /** Per-frame RPE: frames between the poses of a pair. */
  std::size_t rpe_delta = 1;
};

/** Every metric of one estimate against one reference: ATE (aligned and not), per-frame RPE,
 *  KITTI RPE. */
struct TrajectoryEvaluation {
  /** Number of paired poses. */
  std::size_t poses = 0;
  /** Path length of the reference (m). */
  double reference_path_length = 0.0;
  AbsoluteError ate; ///< with options.alignment
  /** ATE without any alignment. */
  AbsoluteError ate_unaligned;
  KittiRelativeError kitti; ///< on the aligned estimate (only Sim3 changes it)
  FrameRelativeError rpe;   ///< likewise
};

/** What the errors can be computed from: every pose one a file may give (io::poseProblem:
 *  a rigid motion within 1e9 m; beyond, differences and squares lose everything or
 *  overflow to inf). Throws std::invalid_argument "NAME: pose I (from 1) ...". */
void
requireRigidMotions(const Poses& poses, const std::string& name);

/** Throws std::invalid_argument when the lists differ in size or hold fewer than 2 poses,
 *  when a pose is not a rigid motion (requireRigidMotions), or when the alignment is
 *  degenerate (see umeyamaAlignment). */
TrajectoryEvaluation
evaluateTrajectory(const Poses& estimate,
                   const Poses& reference,
                   const EvaluationOptions& options = {});

/** Distance along a path: sum of |p_i - p_{i-1}| (the devkit's trajectoryDistances). */
std::vector<double>
pathDistances(const Poses& poses);

} // namespace evaluation
} // namespace pcl_parallel
