/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * `pcl_pslam simulate --preset NAME OUT_DIR`: a preset written in the app's input formats
 * with its ground truth (sim::simulateToDirectory).
 */
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace pcl_pslam {

/** Runs the command on its arguments (after "simulate"); returns the exit status: 0, 1 for
 *  a failure writing the data, 2 for bad usage. */
int
simulateCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

} // namespace pcl_pslam
