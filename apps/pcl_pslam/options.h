/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pcl_pslam's command line (Boost.Program_options): subcommands, and within `run` 3DTK
 * slam6D's option names wherever the meaning is the same.
 */
#pragma once

#include <pcl_parallel/io/scan_directory.h>
#include <pcl_parallel/slam/mapping.h>

#include <limits>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace pcl_pslam {

using Cloud = pcl_parallel::slam::Cloud;
using Poses = pcl_parallel::slam::Poses;
using Result = pcl_parallel::slam::MappingResult;

/** A command line pcl_pslam cannot run: the caller prints one line and exits with 2. */
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/** Bad data (a scan, a poses file, ...): one line naming the file, exit 1. The scan
 *  directory's reader throws it. */
using DataError = pcl_parallel::io::ScanDataError;

/** What the command line asks for. The input's (ScanDirectoryOptions) and the lengths the
 *  user gives are in the files' units (3DTK: those of the scan data, e.g. cm for uos) and
 *  are scaled with the data (toParameters); unset lengths take the defaults, in metres. */
struct Options : pcl_parallel::io::ScanDirectoryOptions {
  std::string command;           ///< demo, run, simulate, evaluate
  bool help = false;             ///< --help: print helpText(command), exit 0
  std::vector<std::string> rest; ///< simulate / evaluate: their arguments, for their parsers
  std::string out = "pcl_pslam_out";

  std::optional<double> voxel, icp_distance, icp_final, loop_distance, lum_distance, lum_final;
  int icp_iterations = pcl_parallel::slam::MatcherParameters().max_iterations;
  int loop_size = pcl_parallel::slam::LoopClosureParameters().min_separation;
  int lum_iterations = pcl_parallel::slam::LoopClosureParameters().lum_iterations;
  std::optional<double> eps_icp, eps_slam; ///< unset: the pipeline's defaults
  bool metascan = false;     ///< against a map of previous scans (the pipeline's default)
  bool scan_to_scan = false; ///< against the previous scan only (the paper's default)
  bool deskew = false;
  double sweep_period = 0.0; ///< seconds a sweep takes; 0: scans are consecutive sweeps
  bool sweep_ccw = false;    ///< the head turns counter-clockwise in the scans' frame
  bool map_normals = false;  ///< point-to-plane normals on the local map (sparse scanners)
  bool no_loops = false;
  bool no_pose_search = false;
  int elch = 4; ///< [-L] 3DTK's loop closing algorithm: 0 none, else ELCH
  bool no_sequence_constraints = false;
  unsigned threads = 0;
  /** Scans per segment of the segmented front end (0: one front end over the sequence;
   *  under mpirun with several ranks, unset means one segment per rank) */
  std::optional<std::size_t> segment_size;
  std::size_t segment_overlap = 5; ///< scans each segment shares with the previous one
  bool quiet = false;
  bool ply = false;                ///< also write map.ply
  bool picture = true;             ///< write map.png
  std::string style = "auto";      ///< map.png: auto, height, floorplan
  std::optional<double> map_voxel; ///< map.pcd's voxel (files' units; default: --voxel)
  std::string preset = "office";   ///< demo: the simulated preset
  std::string keep; ///< demo: keep the simulated scans here (default: a temp dir)
};

/** Parses argv. Throws UsageError (message: one line) for anything it cannot run. */
Options
parseCommandLine(int argc, const char* const* argv);

/** The help of a command ("" : the overview), every option with its default and unit. */
std::string
helpText(const std::string& command);

/** The pipeline's parameters, lengths converted to metres: given lengths times `scale`
 *  (the factor that took the files' coordinates to metres), defaults as they are. */
pcl_parallel::slam::Parameters
toParameters(const Options& o, double scale);

/** How the sequence is spread: over the ranks when there are several, else in segments
 *  with --segment-size, else online. */
pcl_parallel::slam::MappingOptions
toMappingOptions(const Options& o, int ranks);

/** Map voxel size in metres (map_voxel scaled, else the reduction voxel, else 0.1 m when
 *  the reduction voxel is automatic). */
double
mapVoxel(const Options& o, double scale);

} // namespace pcl_pslam
