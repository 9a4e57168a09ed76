/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/sim/scene.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <cmath>
#include <cstdint>
#include <functional>
#include <vector>

namespace pcl_parallel {
namespace sim {

/**
 * A 3D laser scanner in its own frame (x forward, y left, z up): a grid of rays, columns
 * by rows, with Gaussian range noise.
 *
 * - Spherical: column c looks at azimuth a_c = pi * (1 - 2 (c + 0.5) / azimuth_steps),
 *   i.e. the head turns clockwise seen from above, starting behind the sensor (KITTI's
 *   HDL-64E and KISS-ICP's convention); row r at elevation min_elevation +
 *   (max_elevation - min_elevation) r / (elevation_steps - 1). A spinning multi-beam
 *   lidar, a 2D scanner in a vertical plane turned about z (Wulf's rotating scanner, Sec.
 *   VI-C) or a terrestrial scanner.
 * - TiltingLine: Kurt3D's scanner (Sec. VI-B): a 2D scanner with elevation_steps beams
 *   over line_fov in front (beam angle from +line_fov/2, left, to -line_fov/2), whose
 *   plane a servo pitches through azimuth_steps positions from min_elevation (down) to
 *   max_elevation (up): a front hemisphere for +-90 degrees.
 *
 * No return within max_range is a dropout (no point), unless max_range_points asks for
 * a point at max_range (as 3DTK's raw data holds at 3276.7 cm). A return nearer than
 * min_range is dropped.
 */
struct ScannerModel {
  /** The scan patterns: a spinning head (columns of beams), or Kurt3D's tilting line. */
  enum class Pattern { Spherical, TiltingLine };
  /** Which pattern. */
  Pattern pattern = Pattern::Spherical;
  int azimuth_steps = 720;       ///< columns: azimuths (Spherical) or servo positions
  int elevation_steps = 96;      ///< rows: beams per column
  double min_elevation = -0.6;   ///< radians; TiltingLine: lowest servo pitch
  double max_elevation = 0.9;    ///< radians; TiltingLine: highest servo pitch
  double line_fov = M_PI;        ///< TiltingLine: the 2D scanner's fan, radians
  double min_range = 0.3;        ///< metres; closer returns are dropped
  double max_range = 30.0;       ///< metres; no return beyond
  double range_noise = 0.005;    ///< standard deviation of the range, metres
  bool max_range_points = false; ///< a point at max_range for a ray without a return
  /** Probability that a ray across a depth edge (its neighbour half a column on
   *  differs by more than mixed_pixel_gap) returns a range between the two surfaces, as
   *  a beam whose footprint straddles the edge does. 0: no mixed pixels. */
  double mixed_pixel_probability = 0.0;
  double mixed_pixel_gap = 0.3; ///< metres
  /** Seconds per revolution while moving (Spherical only): > 0 takes column c at sweep
   *  time t_c = (c + 0.5) / azimuth_steps in [0, 1), i.e. t = 0.5 (1 - atan2(y, x) / pi)
   *  of its points, from the pose at that time. 0: stop-and-go, one pose a scan. */
  double sweep_period = 0.0;
};

/** True for a horizontal 2D scanner: a TiltingLine at one level pitch, whose points lie
 *  in its x-y plane (the 2D presets; written as KITTI scan sets, z up). */
inline bool
isPlanar(const ScannerModel& s)
{
  return s.pattern == ScannerModel::Pattern::TiltingLine && s.azimuth_steps == 1 &&
         s.min_elevation == 0.0;
}

/** The unit direction of ray (column, row) in the scanner's frame. */
Eigen::Vector3d
rayDirection(const ScannerModel& scanner, int column, int row);

/** Sweep time in [0, 1) of a point in the sensor frame of a clockwise spinning scanner
 *  whose sweep starts behind it (KITTI; KISS-ICP's GetTimestamps for KITTI):
 *  t = 0.5 (1 - atan2(y, x) / pi). */
inline double
sweepTime(double x, double y)
{
  return 0.5 * (1.0 - std::atan2(y, x) / M_PI);
}

/** A deterministic standard normal and uniform for (key, ray): a counter-based
 *  generator (SplitMix64's finaliser over the key and the ray index), so noise does not
 *  depend on which thread casts which ray. */
double
counterNormal(std::uint64_t key, std::uint64_t ray);
/** A uniform number in [0, 1) from the counter-based generator at (\a key, \a ray). */
double
counterUniform(std::uint64_t key, std::uint64_t ray);

/** A key for scan `scan` of a set simulated with `seed`. */
std::uint64_t
scanKey(std::uint64_t seed, std::uint64_t scan);

/** Throws std::invalid_argument naming the problem for an inconsistent model. */
void
validate(const ScannerModel& scanner);

/**
 * One scan. pose_of_column(c) gives the scanner's pose (p_world = pose * p_scanner) when
 * it takes column c; points are written in the scanner's frame at that moment, so a scan
 * taken while moving is skewed by the motion. Rays are cast in parallel (columns split
 * over num_threads, 0 = all cores); the noise of ray k comes from (key, k) alone, so the
 * scan is bit-identical for any thread count. Points come column by column. When times
 * is given it receives each point's sweep time (c + 0.5) / azimuth_steps.
 */
pcl::PointCloud<pcl::PointXYZ>::Ptr
castScan(const RayCaster& caster,
         const ScannerModel& scanner,
         const std::function<Eigen::Matrix4d(int column)>& pose_of_column,
         std::uint64_t key,
         unsigned num_threads = 0,
         std::vector<float>* times = nullptr);

/** A stop-and-go scan from one pose. */
pcl::PointCloud<pcl::PointXYZ>::Ptr
castScan(const RayCaster& caster,
         const ScannerModel& scanner,
         const Eigen::Matrix4d& pose,
         std::uint64_t key,
         unsigned num_threads = 0);

} // namespace sim
} // namespace pcl_parallel
