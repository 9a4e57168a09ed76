/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * `pcl_pslam simulate --preset NAME [--seed N] OUT_DIR`: a simulated scan set written in
 * the app's own input formats, with ground_truth.txt (sim/presets.h, sim/scan_set_writer.h).
 */
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace pcl_pslam {

/** Runs the command on its arguments (after "simulate"); returns the exit status:
 *  0, 1 for a failure writing the data, 2 for bad usage. */
int
simulateCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

} // namespace pcl_pslam
