/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pcl_pslam's outputs: 3DTK .frames, KITTI and TUM poses, the map (PCD, PLY), map.png and
 * report.json. Every file is written to a temporary name in its directory and renamed, so
 * it is either complete or absent, whatever stops the run (io::writeAtomically).
 */
#pragma once

#include "input.h"
#include "options.h"
#include "progress.h"
#include "slam_pipeline.h"

#include <functional>
#include <ostream>
#include <string>
#include <vector>

namespace pcl_pslam {

/** Creates `dir` (with parents) and checks that a file can be created in it, before any
 *  work. Throws UsageError naming the directory otherwise. Returns true when it created
 *  the directory (so a run stopped before writing can remove it again). */
bool
prepareOutputDirectory(const std::string& dir);

/** scanNNN.frames as slam6D writes it (io::writeFrames, 12 significant digits,
 *  translations divided by `scale`): the initial pose (INVALID, as slam6D's first line),
 *  after ICP (ICP), final (LUM); the first scan, held fixed, ICPINACTIVE. */
void
writeScanFrames(const std::string& path,
                const Eigen::Matrix4d& initial,
                const Eigen::Matrix4d& icp,
                const Eigen::Matrix4d& final_pose,
                bool fixed,
                double scale);

/** The merged map: every scan of `in`, read again at full resolution (a few at once),
 *  deskewed with o.deskew by the motion at its pose (slam::sweepMotionAt) and moved by
 *  it, one centroid per voxel of voxel_size (filters::VoxelCentroidMap: memory per voxel,
 *  not per point; no int32 voxel-index overflow), on o.threads. voxel_size <= 0 keeps
 *  every point. `step` is called after each scan (done, total). */
Cloud::Ptr
buildMap(const Options& o,
         const Input& in,
         const Poses& poses,
         double voxel_size,
         const std::function<void(int, int)>& step = {},
         std::size_t begin = 0,
         std::size_t end = std::size_t(-1));

/** A rank's part of the map under MPI: "map_rank<rank><extension>". */
std::string
mapTileName(int rank, const char* extension);

/** Under MPI, every rank's part of the map: the scans it matched (Result::own_begin,
 *  own_end), read again, as map_rank<rank>.pcd (and .ply with --ply) in o.out.
 *  writeOutputs then reads all tiles back for map.png and names them. */
void
writeMapTile(const Options& o, const Input& in, const Result& r, ProgressReporter& progress);

/** Everything a run writes into o.out, in order, with a progress update (and so a check
 *  for SIGINT/SIGTERM) between files. Returns the names written. `pipeline_result`
 *  scans are the input's; `command_line` goes into report.json. */
std::vector<std::string>
writeOutputs(const Options& o,
             const Input& in,
             const Result& r,
             ProgressReporter& progress,
             const std::string& command_line);

/** The errors of the odometry, the front end and the final poses against the truth
 *  (ATE after SE(3) alignment, KITTI-style RPE, per-frame RPE; evaluation/), a table. */
void
printTruthErrors(std::ostream& out, const Input& in, const Result& r);

/** The run's summary on standard output: matches that failed, the graph, where loop
 *  closing and the front end disagree most, stage times (unless quiet), the errors
 *  against the truth (demo), the files written; on standard error a warning where the
 *  scans contradict the odometry (slam::kOdometryDisagreementLimit). */
void
printSummary(const Options& o,
             const Input& in,
             const Result& r,
             const std::vector<std::string>& written,
             double seconds);

} // namespace pcl_pslam
