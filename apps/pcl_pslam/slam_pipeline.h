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

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <cstdint>
#include <functional>
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
};

/** Progress: a stage name ("reduce", "icp", "lum"), steps done, steps in all. */
using Progress = std::function<void(const std::string& stage, int done, int total)>;

struct Result {
  Poses icp;                                                  ///< after sequential pICP
  Poses final;                                                ///< after pLUM
  std::vector<std::pair<std::uint32_t, std::uint32_t>> links; ///< pLUM's graph
  int icp_failures = 0; ///< pICP matches that did not converge (odometry step kept)
  int lum_iterations = 0;
  std::vector<Cloud::Ptr> reduced; ///< the scans as matched
  pcl_parallel::slam::StageTimes times;              ///< seconds per stage
  std::vector<pcl_parallel::slam::ScanReport> reports; ///< per scan
  int relaxations = 0;                               ///< pLUM runs
  std::size_t bytes_per_scan = 0;                    ///< kept by the pipeline
  pcl_parallel::slam::FrontEndParameters front_end;      ///< as resolved (lengths in m)
  pcl_parallel::slam::LoopClosureParameters loop_closure; ///< likewise
};

/** Voxel-grid reduction (centroid per occupied voxel); a copy when voxel_size <= 0. */
Cloud::Ptr
reduce(const Cloud::ConstPtr& scan, double voxel_size);

/** Runs the pipeline from initial poses (odometry; the first pose is kept fixed).
 *  Throws std::invalid_argument for fewer than 2 scans, mismatched sizes, an empty scan
 *  or non-finite initial poses. */
Result
run(const std::vector<Cloud::Ptr>& scans,
    const Poses& initial,
    const Parameters& params,
    const Progress& progress = Progress());

/** The merged map: every scan moved by its pose, reduced with voxel_size. */
Cloud::Ptr
mergedMap(const std::vector<Cloud::Ptr>& scans, const Poses& poses, double voxel_size);

/** A top view of the map (the plane normal to `up`, 0 = x, 1 = y, 2 = z) as an RGB PNG
 *  about `size` pixels on its long side: points within 0.8 m (map units taken as metres)
 *  of the trajectory's heights dark by density, like a floor plan, the others light
 *  grey, the poses in red. Throws std::runtime_error if the file cannot be written. */
void
writeTopView(const std::string& path,
             const Cloud& map,
             const Poses& trajectory,
             int up = 2,
             int size = 1000);

/** Poses as KITTI lines: the top three rows of each 4x4, row-major, 12 numbers. */
void
writePoses(const std::string& path, const Poses& poses);

/** Max and mean rotation (rad) and translation errors of a against b. */
struct Errors {
  double max_rot = 0, mean_rot = 0, max_trans = 0, mean_trans = 0;
};
Errors
poseErrors(const Poses& a, const Poses& b);

} // namespace pcl_pslam
