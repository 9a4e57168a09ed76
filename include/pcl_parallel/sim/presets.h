/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/sim/simulated_scans.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace sim {

/**
 * Scan sets sized like the paper's experiments (Sec. VI) and KITTI, deterministic for a
 * seed and identical for any thread count:
 * - office:   11 scans x ~85k points, Kurt3D's tilting SICK (181 beams x 470 pitches,
 *             front hemisphere), stop-and-go, one loop on an office floor (Table I);
 * - hannover: 468 scans x ~20k points, a 2D scanner turned about z (Wulf's rotating
 *             scanner), stop-and-go, several loops through a building (Sec. VI-C);
 * - riegl:    11 scans x ~300k points, a terrestrial scanner on a street and square over
 *             uneven ground, one loop (Table II);
 * - kitti:    420 scans x ~120k points, a 64-beam lidar at 10 Hz taking raw (skewed)
 *             scans while driving 9 m/s around a block over uneven ground and a ramp, the
 *             last ~40 m revisiting the start (see SimulatedScanSet for the sweep times);
 * - office2d, hannover2d: 150 and 800 scans x ~170 points, a horizontal 2D scanner (180
 *             beams, 1 degree, 80 m; the CARMEN logs' SICK) on a robot driving the office
 *             loop and the building's corridors, wheel odometry (paper Sec. VII);
 * - handheld: 130 sweeps x 64k points, a 32-beam lidar (-30 to +30 degrees, 2000
 *             columns) spinning at 2 Hz, carried at 0.5-1.1 m a sweep through a
 *             split-level building, up one flight of stairs and down another, looking
 *             round (+-30 degrees off the heading) and tilting (+-8 pitch, +-5 roll):
 *             up to 60 degrees of turn a sweep, skewed sweeps, the start revisited.
 * Every preset has drifting odometry: per step of length L, Gaussian errors of
 * translation_noise * L along and across the heading and heading_noise * L in yaw,
 * composed onto the true step (pitch, roll and height come from the truth, as from an
 * IMU).
 */
struct PresetOptions {
  /** Random seed: the same seed, the same scans. */
  std::uint32_t seed = 1;
  unsigned num_threads = 0; ///< 0: all cores; the result does not depend on it
  /** Simulate only the first max_scans scans (tests, previews); < 0: all. */
  int max_scans = -1;
  /** Keep every stride-th scan of the preset (>= 1): on `kitti`, keyframes of a 10 Hz
   *  sensor stride sweeps apart, each still one sweep's skew (max_scans counts kept
   *  scans). */
  int stride = 1;
  /** Beams (rows) of the scanner over the preset's field of view, 2 to 4096; 0 keeps the
   *  preset's: `kitti` with 16 is a VLP-16-like sparse sensor over the same drive. */
  int beams = 0;
  /** Odometry noise overrides: fraction of the distance (translation) and radians per
   *  metre (heading); < 0 keeps the preset's value. */
  double odometry_translation_noise = -1.0;
  /** Heading noise override (rad/m); < 0 keeps the preset's value. */
  double odometry_heading_noise = -1.0;
  /** Truth, odometry and timestamps only: no ray casting, the scans are left empty
   *  (routes, loops and drift at no cost). */
  bool poses_only = false;
  /** Called after each scan with (scans done, scans in all), from the calling thread. */
  std::function<void(int, int)> progress;
};

/** The preset names, in the order above. */
std::vector<std::string>
presetNames();

/** One line describing a preset (scans, points, scanner, scene). Throws
 *  std::invalid_argument on an unknown name, listing the known ones. */
std::string
presetDescription(const std::string& name);

/** Simulates a preset. Throws std::invalid_argument on an unknown name (listing the
 *  known ones) or a bad option. */
SimulatedScanSet
simulatePreset(const std::string& name, const PresetOptions& options);

/** The preset \a name simulated with \a seed on \a num_threads threads (0: all cores). */
SimulatedScanSet
simulatePreset(const std::string& name, std::uint32_t seed = 1, unsigned num_threads = 0);

} // namespace sim
} // namespace pcl_parallel
