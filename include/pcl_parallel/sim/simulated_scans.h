/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <cstdint>
#include <vector>

namespace pcl_parallel {
namespace sim {

/** A solid axis-aligned box (walls, floor, crates). */
struct Box {
  Eigen::Vector3d min;
  Eigen::Vector3d max;
};

/** A solid vertical cylinder (pillars): axis through (x, y), from z_min to z_max. */
struct Cylinder {
  double x = 0.0, y = 0.0, radius = 0.5;
  double z_min = 0.0, z_max = 3.0;
};

/** The world the scanner sees: solid primitives, metres. */
struct World {
  std::vector<Box> boxes;
  std::vector<Cylinder> cylinders;

  /** Distance along the unit direction dir from origin to the first surface hit with
   *  distance in (0, max_range]; returns false if there is none. A ray starting inside
   *  a solid hits its far side. */
  bool
  raycast(const Eigen::Vector3d& origin,
          const Eigen::Vector3d& dir,
          double max_range,
          double& range) const;
};

/** A 3D laser scanner: a grid of rays in its own frame (x forward, y left, z up), as a
 *  rotating 2D scanner or a multi-beam lidar produces, with Gaussian range noise. */
struct ScannerModel {
  int azimuth_steps = 720;     ///< rays per revolution about z
  int elevation_steps = 96;    ///< rays per column
  double min_elevation = -0.6; ///< radians, below the horizon
  double max_elevation = 0.9;  ///< radians
  double min_range = 0.3;      ///< metres; closer returns are dropped
  double max_range = 30.0;     ///< metres; no return beyond
  double range_noise = 0.005;  ///< standard deviation of the range, metres
};

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
  ScannerModel scanner;
  /** Odometry error per step: heading noise (radians) and translation noise as a
   *  fraction of the step, both Gaussian standard deviations. It accumulates, so the
   *  odometry drifts as a wheel odometry does. */
  double odometry_heading_noise = 0.01;
  double odometry_translation_noise = 0.02;
  std::uint32_t seed = 1;
};

/** The simulated scans, each in its scanner's frame, with true and odometry poses
 *  (p_world = pose * p_scan). odometry[0] = truth[0]. */
struct SimulatedScanSet {
  std::vector<pcl::PointCloud<pcl::PointXYZ>::Ptr> scans;
  std::vector<Eigen::Matrix4d> truth;
  std::vector<Eigen::Matrix4d> odometry;
  World world;
};

/** The building floor of the parameters (walls, floor, ceiling, obstacles). */
World
makeCorridorWorld(const SimulationParameters& params);

/** One scan of the world from a pose (scanner frame), rays in parallel. The noise comes
 *  from `seed` alone, so a scan is the same for any thread count. */
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
