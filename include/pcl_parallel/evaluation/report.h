/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Two trajectory files compared as `pcl_pslam evaluate` compares them: their poses paired
 * (by time stamp as evo associates them, else by index) and the evaluation as a table.
 */
#pragma once

#include <pcl_parallel/evaluation/trajectory_error.h>
#include <pcl_parallel/io/pose_files.h>

#include <ostream>
#include <string>

namespace pcl_parallel {
namespace evaluation {

/** The estimate's and the truth's poses paired, and how, in words. */
struct PairedTrajectories {
  Poses estimate, truth;
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

} // namespace evaluation
} // namespace pcl_parallel
