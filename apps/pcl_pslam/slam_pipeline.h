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

#include <pcl_parallel/slam/mapping.h>
#include <pcl_parallel/slam/pipeline.h>

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
  std::size_t bytes_per_scan = 0;             ///< kept by the pipeline
  pcl_parallel::slam::Parameters parameters;  ///< as resolved (lengths in m)
  pcl_parallel::slam::MappingOptions mapping; ///< how the sequence was spread
  pcl_parallel::slam::MappingReport spread;   ///< what the backend did (segments, ranks)
};

/** Scan k (0-based), read when the pipeline needs it: its points and, if the file has
 *  them, their times (`point_times`; odometry and stamp come from run's arguments). */
using ScanReader = std::function<pcl_parallel::slam::SourceScan(std::size_t k)>;

/** Maps scans 0..n-1 (slam::mapSequence with `mapping`'s backend): each scan is read,
 *  matched and dropped (the pipeline keeps its reduced points only). `odometry`: a pose
 *  per scan, each pICP starting from its step (the first pose kept fixed); empty: none,
 *  constant velocity from the identity. `stamps`: each scan's time (s), or none.
 *  Progress: the backend's stages, then "pLUM". Throws std::invalid_argument for fewer
 *  than 2 scans, mismatched sizes, an empty scan or non-finite poses. */
Result
run(const ScanReader& read,
    std::size_t n,
    const Poses& odometry,
    const std::vector<double>& stamps,
    const pcl_parallel::slam::Parameters& params,
    const pcl_parallel::slam::MappingOptions& mapping,
    const Progress& progress = Progress());

/** The same over scans in memory, online, without stamps. */
Result
run(const std::vector<Cloud::Ptr>& scans,
    const Poses& odometry,
    const pcl_parallel::slam::Parameters& params,
    const Progress& progress = Progress());

} // namespace pcl_pslam
