/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Two trajectory files compared as `pcl_pslam evaluate` compares them: their poses paired
 * (by time stamp as evo associates them, else by index) and the evaluation as a table.
 * evaluateFiles returns what the command prints, as a structure; toJson writes it as JSON.
 */
#pragma once

#include <pcl_parallel/evaluation/trajectory_error.h>
#include <pcl_parallel/io/pose_files.h>

#include <ostream>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace evaluation {

/** The estimate's and the truth's poses paired, and how, in words. */
struct PairedTrajectories {
  /** The paired estimate and ground-truth poses. */
  ///@{
  Poses estimate, truth;
  ///@}
  /** How the poses were paired (by time stamp or by index), in words. */
  std::string association;
};

/** Pairs by time stamp where both trajectories have them (associateByTimestamp within
 *  `max_diff` s), else by index: the first min(n, m) poses with `truncate`, else only
 *  trajectories of the same length. Throws std::runtime_error naming both paths where no
 *  pair is found or the lengths differ. */
PairedTrajectories
pairTrajectories(const io::Trajectory& estimate,
                 const std::string& estimate_path,
                 const io::Trajectory& truth,
                 const std::string& truth_path,
                 double max_diff,
                 bool truncate);

/** "PATH (format, N poses[, timestamps])". */
std::string
describe(const std::string& path, const io::Trajectory& trajectory);

/** The evaluation as a table: ATE (aligned and not), per-frame RPE, KITTI RPE per length. */
void
printEvaluation(std::ostream& out, const TrajectoryEvaluation& evaluation);

/** KITTI RPE segment lengths from text: "auto" none (kittiLengthsFor decides), "kitti" the
 *  devkit's, else comma-separated positive lengths in metres. Throws std::invalid_argument. */
std::vector<double>
kittiLengthsFromString(const std::string& text);

/** How evaluateFiles reads, pairs and evaluates two trajectory files. */
struct FileEvaluationOptions {
  /** The metrics' options (alignment, KITTI lengths and step, RPE delta). */
  EvaluationOptions evaluation;
  double max_diff = 0.01;               ///< pairing by time stamp: largest difference (s)
  double frames_unit = io::kFramesUnit; ///< metres per unit of .frames translations
  bool truncate = false;                ///< pairing by index: the first min(n, m) poses
};

/** Two trajectory files evaluated: what was read, how it was paired, the errors. */
struct FileEvaluation {
  /** The paths of the two files as given. */
  ///@{
  std::string estimate_path, truth_path;
  ///@}
  /** The two trajectories as read. */
  ///@{
  io::Trajectory estimate, truth;
  ///@}
  std::string association; ///< pairTrajectories' words
  /** The errors of the paired estimate against the truth. */
  TrajectoryEvaluation errors;
};

/** Reads both files (io::loadTrajectory), checks every pose (requireRigidMotions, named by
 *  file), pairs them (pairTrajectories) and evaluates the pairs (evaluateTrajectory).
 *  Throws std::runtime_error or std::invalid_argument naming the file. */
FileEvaluation
evaluateFiles(const std::string& estimate_path,
              const std::string& truth_path,
              const FileEvaluationOptions& options = {});

/** The files (describe), the pairing, the truth's path length, then printEvaluation. */
void
printFileEvaluation(std::ostream& out, const FileEvaluation& evaluation);

/** The evaluation and the files it read as JSON text (`pcl_pslam evaluate --json`), objects
 *  indented by `indent` spaces (-1: one line). A KITTI rate is null where no segment fits. */
std::string
toJson(const FileEvaluation& evaluation, int indent = 2);

/** A trajectory's errors under a name: a row of printErrorRows. */
struct NamedEvaluation {
  /** The row's label (e.g. "front end"). */
  std::string name;
  /** The row's errors. */
  TrajectoryEvaluation errors;
};

/** A mapping run's trajectories against the truth, a row each: "odometry" (where given,
 *  non-empty), "front end" and "final" (ATE after SE(3) alignment, RPE as the KITTI devkit
 *  over kittiLengthsFor(truth), per-frame RPE). */
std::vector<NamedEvaluation>
evaluateRun(const Poses& odometry,
            const Poses& front_end,
            const Poses& final_poses,
            const Poses& truth);

/** Several trajectories' errors side by side, a header line and a line each: the ATE's
 *  RMSE (m, deg), the KITTI RPE (%, deg/m) and the per-frame RPE's RMSE (m). */
void
printErrorRows(std::ostream& out, const std::vector<NamedEvaluation>& rows);

} // namespace evaluation
} // namespace pcl_parallel
