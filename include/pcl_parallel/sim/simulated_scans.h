/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/sim/scanner.h>
#include <pcl_parallel/sim/scene.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace sim {

/**
 * \brief Parameters of the built-in simulated scan set: a robot driving loops around the
 * ring corridor of a building floor, scanning every step_length metres.
 *
 * The floor is an outer rectangle of outer_length x outer_width with a solid inner block
 * that leaves a corridor of corridor_width all round; crates and pillars stand along both
 * walls (placed by the seed), so that every scan sees structure in all directions (a bare
 * corridor leaves scan matching unconstrained along its axis).
 */
struct SimulationParameters {
  double outer_length = 30.0;  ///< metres (x)
  double outer_width = 20.0;   ///< metres (y)
  double corridor_width = 4.0; ///< metres
  double height = 3.0;         ///< floor to ceiling, metres
  /** Mean distance between crates and pillars along each wall of the corridor, metres;
   *  0 leaves the walls bare. */
  double obstacle_spacing = 2.5;
  double step_length = 1.5;    ///< metres between scans along the centre line
  double laps = 1.1;           ///< > 1 revisits the start: a loop closure
  double scanner_height = 1.0; ///< metres above the floor
  /** The scanner. */
  ScannerModel scanner;
  /** Odometry error per step: heading noise (radians) and translation noise as a
   *  fraction of the step, both Gaussian standard deviations. It accumulates, so the
   *  odometry drifts as a wheel odometry does. */
  double odometry_heading_noise = 0.01;
  /** Odometry translation noise (fraction of the distance). */
  double odometry_translation_noise = 0.02;
  /** Random seed. */
  std::uint32_t seed = 1;
};

/**
 * The simulated scans, each in its scanner's frame, with true and odometry poses
 * (p_world = pose * p_scan, frame x forward, y left, z up). odometry[0] = truth[0].
 *
 * A scan taken while moving (scanner.sweep_period > 0, the `kitti` preset) is raw: the
 * head turns clockwise, column by column, and each point is written in the sensor frame
 * at the moment its column was taken. point_times[i][k] is point k's sweep time in
 * [0, 1): the sensor pose at that moment is the pose at timestamps[i] + (t - 0.5) *
 * sweep_period. It equals t = 0.5 (1 - atan2(y, x) / pi) of the point (KITTI's
 * convention, KISS-ICP's GetTimestamps), so a pipeline can deskew from the points alone;
 * truth[i] and odometry[i] are the poses at mid-sweep t = 0.5. For stop-and-go scans
 * point_times is empty.
 */
struct SimulatedScanSet {
  /** The scans, each in its sensor's frame. */
  std::vector<pcl::PointCloud<pcl::PointXYZ>::Ptr> scans;
  /** True poses. */
  std::vector<Eigen::Matrix4d> truth;
  /** Drifting odometry poses. */
  std::vector<Eigen::Matrix4d> odometry;
  /** The world the scans were cast in. */
  World world;
  std::vector<std::vector<float>> point_times; ///< per scan, per point; empty: stop-and-go
  std::vector<double> timestamps;              ///< seconds, scan i at mid-sweep
  ScannerModel scanner;                        ///< the model that took the scans
  std::string name;                            ///< the preset, or "corridor"
};

/** The building floor of the parameters (walls, floor, ceiling, obstacles). */
World
makeCorridorWorld(const SimulationParameters& params);

/** One stop-and-go scan of the world from a pose (scanner frame), rays in parallel. The
 *  noise comes from `seed` alone, so a scan is the same for any thread count. Builds a
 *  RayCaster for the world each call: for many scans use castScan. */
pcl::PointCloud<pcl::PointXYZ>::Ptr
simulateScan(const World& world,
             const ScannerModel& scanner,
             const Eigen::Matrix4d& pose,
             std::uint32_t seed,
             unsigned num_threads = 0);

/** The whole scan set. Deterministic for given parameters, whatever the thread count.
 *  Throws std::invalid_argument for parameters that leave no corridor or no scans. */
SimulatedScanSet
simulateScanSet(const SimulationParameters& params = SimulationParameters(),
                unsigned num_threads = 0);

} // namespace sim
} // namespace pcl_parallel
