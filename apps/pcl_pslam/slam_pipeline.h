/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The pcl_pslam pipeline (the paper's slam6D with pICP and pLUM): reduce every scan,
 * match each scan to its predecessor with pICP from the odometry, detect loops by pose
 * distance, relax all poses with pLUM, write poses, the merged map and a picture of it.
 * Kept out of main.cpp so the tests drive it directly.
 */
#pragma once

#include <pcl_parallel/slam/pipeline.h>
#include <pcl_parallel/slam/segments.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace pcl_pslam {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Poses = std::vector<Eigen::Matrix4d>;

/** The library pipeline's parameters (slam::Parameters: lengths 0 = automatic) and how
 *  to read the initial poses. */
struct Parameters : pcl_parallel::slam::Parameters {
  /** true: the initial poses are odometry, each pICP starts from its step. false: they
   *  carry no motion; the front end predicts by constant velocity from the identity. */
  bool odometry = true;
  /** Each scan's time (s), passed on with it (deskewing by sweep_period needs them);
   *  empty: none. */
  std::vector<double> stamps;
  /** Scans per segment (slam::mapSegments); 0: one front end over the sequence. */
  std::size_t segment_size = 0;
  std::size_t segment_overlap = 5;
  /** Spread the segments and pLUM over the ranks of MPI_COMM_WORLD (mpi::mapSegments);
   *  MPI must be initialised. */
  bool mpi = false;
};

/** Progress: a stage name ("reduce", "icp", "lum"), steps done, steps in all. */
using Progress = std::function<void(const std::string& stage, int done, int total)>;

struct Result {
  Poses icp;                                                  ///< after sequential pICP
  Poses final;                                                ///< after pLUM
  std::vector<std::pair<std::uint32_t, std::uint32_t>> links; ///< pLUM's graph
  int icp_failures = 0; ///< pICP matches that did not converge (odometry step kept)
  int lum_iterations = 0;
  pcl_parallel::slam::StageTimes times;                ///< seconds per stage
  std::vector<pcl_parallel::slam::ScanReport> reports; ///< per scan
  int relaxations = 0;                                 ///< pLUM runs
  /** With odometry: slam::odometryDisagreement of the scans (none: too few steps, or
   *  too short). */
  std::optional<double> odometry_disagreement;
  std::size_t bytes_per_scan = 0;                         ///< kept by the pipeline
  pcl_parallel::slam::FrontEndParameters front_end;       ///< as resolved (lengths in m)
  pcl_parallel::slam::LoopClosureParameters loop_closure; ///< likewise
  /** Segmented runs: the segments, and the scans [own_begin, own_end) this rank matched
   *  (all of them in one process) */
  std::size_t segments = 0, segment_size = 0, own_begin = 0, own_end = 0;
  int rank = 0, ranks = 1;
  double wait_seconds = 0.0;      ///< MPI: waiting for the other ranks' front ends
  std::uint64_t bytes_shared = 0; ///< MPI: sent between ranks outside pLUM
  std::size_t scans_sent = 0;     ///< MPI: scans sent to the rank of a link to them
  std::size_t max_kept_scans = 0; ///< MPI: the most scans whose points one rank keeps
};

/** Scan k (0-based), read when the pipeline needs it: its points and, if the file has
 *  them, their times (`point_times`; odometry and stamp come from run's arguments). */
using ScanReader = std::function<pcl_parallel::slam::SourceScan(std::size_t k)>;

/** Streams scans 0..n-1 through slam::Pipeline from initial poses (odometry, when
 *  params.odometry; the first pose is kept fixed), then finish(): each scan is read,
 *  matched and dropped (the pipeline keeps its reduced points only). Progress: ("icp",
 *  scans done, scans). Throws std::invalid_argument for fewer than 2 scans, mismatched
 *  sizes, an empty scan or non-finite initial poses. */
Result
run(const ScanReader& read,
    std::size_t n,
    const Poses& initial,
    const Parameters& params,
    const Progress& progress = Progress());

/** The same over scans in memory. */
Result
run(const std::vector<Cloud::Ptr>& scans,
    const Poses& initial,
    const Parameters& params,
    const Progress& progress = Progress());

} // namespace pcl_pslam
