/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pcl_pslam's outputs: the library's pose, map and picture files, report.json and the
 * summary, written into a temporary directory and swapped in as one unit
 * (io::OutputDirectory), whatever stops the run.
 */
#pragma once

#include "input.h"
#include "options.h"
#include "progress.h"

#include <pcl_parallel/io/output_directory.h>
#include <pcl_parallel/slam/run_outputs.h>

#include <memory>
#include <string>
#include <vector>

namespace pcl_pslam {

/** The temporary directory beside `dir` (--out) that the run writes into and swaps in at
 *  the end (io::OutputDirectory); throws UsageError naming --out where it cannot be used. */
std::unique_ptr<pcl_parallel::io::OutputDirectory>
openOutputDirectory(const std::string& dir);

/** The library's options for the run's files (slam::writeRunOutputs, writeMapTile): map
 *  voxel, PLY, picture and its caption (the errors against the truth, the command). */
pcl_parallel::slam::RunOutputOptions
runOutputOptions(const Options& o, const Input& in, const Result& r);

/** Everything a run writes into `dir`, with a progress update (and so a check for a signal)
 *  between files; `command_line` goes into report.json. Returns the names written. */
std::vector<std::string>
writeOutputs(const Options& o,
             const std::string& dir,
             const Input& in,
             const Result& r,
             ProgressReporter& progress,
             const std::string& command_line);

/** The run's summary on standard output (warnings about the input on standard error). */
void
printSummary(const Options& o,
             const Input& in,
             const Result& r,
             const std::vector<std::string>& written,
             bool replaced,
             double seconds);

} // namespace pcl_pslam
