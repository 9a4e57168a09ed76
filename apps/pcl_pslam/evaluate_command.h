/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * `pcl_pslam evaluate ESTIMATE GROUND_TRUTH`: ATE and RPE of one trajectory file against
 * another (evaluation::evaluateFiles), as a table or as JSON; `pcl_pslam evaluate ESTIMATE
 * --relations FILE`: Kümmerle et al.'s relation error (evaluation::evaluateRelationsFile).
 */
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace pcl_pslam {

/** Runs the command on its arguments (those after "evaluate"): the result on out, errors
 *  as one line on err. Returns the exit code: 0, 1 for bad data, 2 for bad usage. */
int
evaluateCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

} // namespace pcl_pslam
