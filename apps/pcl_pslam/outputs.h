/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pcl_pslam's outputs: the library's pose, map and picture files, report.json and the
 * summary. Every file is complete or absent, whatever stops the run (io::writeAtomically).
 */
#pragma once

#include "input.h"
#include "options.h"
#include "progress.h"

#include <ostream>
#include <string>
#include <vector>

namespace pcl_pslam {

/** Creates `dir` and checks that a file can be created in it, before any work. Throws
 *  UsageError naming it otherwise. True where it created it (for removal after a stop). */
bool
prepareOutputDirectory(const std::string& dir);

/** Under MPI, this rank's part of the map (the scans it matched) as map_rank<rank>.pcd (and
 *  .ply with --ply) in o.out; writeOutputs reads them all back for map.png. */
void
writeMapTile(const Options& o, const Input& in, const Result& r, ProgressReporter& progress);

/** Everything a run writes into o.out, with a progress update (and so a check for a signal)
 *  between files; `command_line` goes into report.json. Returns the names written. */
std::vector<std::string>
writeOutputs(const Options& o,
             const Input& in,
             const Result& r,
             ProgressReporter& progress,
             const std::string& command_line);

/** The odometry's, the front end's and the final poses' errors against the truth. */
void
printTruthErrors(std::ostream& out, const Input& in, const Result& r);

/** The run's summary on standard output (warnings about the input on standard error). */
void
printSummary(const Options& o,
             const Input& in,
             const Result& r,
             const std::vector<std::string>& written,
             double seconds);

} // namespace pcl_pslam
