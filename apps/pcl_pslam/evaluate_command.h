/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * `pcl_pslam evaluate ESTIMATE GROUND_TRUTH`: ATE and RPE of a trajectory file against
 * another (KITTI, TUM, or a directory of 3DTK .frames), as evo and the KITTI devkit compute
 * them (pcl_parallel/evaluation/).
 */
#pragma once

#include <pcl_parallel/evaluation/trajectory_error.h>

#include <nlohmann/json_fwd.hpp>
#include <ostream>
#include <string>
#include <vector>

namespace pcl_pslam {

/** Runs the command on its arguments (those after "evaluate"): the result table (or JSON
 *  with --json) goes to out, errors as one line to err. Returns the exit code: 0, 1 for
 *  bad data (unreadable or malformed files, trajectories that cannot be paired or
 *  aligned), 2 for bad usage. */
int
evaluateCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

/** The evaluation as JSON (the "ate", "ate_unaligned", "rpe_frame", "rpe_kitti" members of
 *  `evaluate --json`), e.g. for a run report. */
nlohmann::json
evaluationToJson(const pcl_parallel::evaluation::TrajectoryEvaluation& ev);

} // namespace pcl_pslam
