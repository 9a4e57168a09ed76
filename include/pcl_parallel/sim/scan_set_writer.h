/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/sim/presets.h>
#include <pcl_parallel/sim/simulated_scans.h>

#include <Eigen/Core>

#include <cstddef>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace sim {

/** Which files writeScanSet writes: Auto is Kitti for a set taken while moving (it has
 *  point_times) or by a 2D scanner (isPlanar: 3DTK's frame has y up), Uos otherwise. */
enum class ScanSetFormat { Auto, Uos, Kitti, Pcd };

/** The format named "auto", "uos", "kitti" or "pcd"; throws std::invalid_argument. */
ScanSetFormat
scanSetFormatFromString(const std::string& name);

/** 3DTK's left-handed frame (x right, y up, z forward) from ours (x forward, y left, z
 *  up): x' = -y, y' = z, z' = x (a reflection, det -1). */
Eigen::Matrix3d
uosAxes();

/** A pose p_world = T p_scan in our frame, in 3DTK's axes: C T C^-1 with C = uosAxes()
 *  (a proper rotation again; units unchanged). */
Eigen::Matrix4d
toUosFrame(const Eigen::Matrix4d& pose);

/**
 * Writes a scan set in pcl_pslam's input formats, so that `pcl_pslam run DIR` reads it
 * back (every file is written under a temporary name, then renamed):
 * - Uos: scanNNN.3d ("x y z" a line, centimetres, 3DTK's axes; see uosAxes), and
 *   scanNNN.pose (the odometry: "x y z" in cm, then "θx θy θz" in degrees with
 *   R = Rx·Ry·Rz, the 3DTK .pose convention read by io::loadUosPose). At most 1000
 *   scans (3DTK's three digits).
 * - Kitti: NNNNNN.bin (little-endian float32 x y z intensity, metres, sensor frame,
 *   intensity 0; raw, skewed sweeps for a moving set), odometry.txt (KITTI pose lines
 *   of the odometry, the sensor's own frame, no camera calibration), times.txt (one
 *   timestamp a scan, seconds, the mid-sweep time).
 * - Pcd: as Kitti, but NNNNNN.pcd (binary PCD: float32 x y z, uint32 t, each point's
 *   time in ns from the sweep's start, as Ouster's driver writes it; 0 for a stop-and-go
 *   set) instead of the .bin files.
 * - all: ground_truth.txt, the true poses as KITTI pose lines in the frame and units the
 *   reader produces (Uos: 3DTK's axes, metres; Kitti, Pcd: the sensor frame, metres), i.e.
 *   what `pcl_pslam run DIR` should recover.
 * Creates dir if needed. Throws std::runtime_error naming the file that cannot be
 * written, std::invalid_argument for a set whose sizes disagree.
 */
void
writeScanSet(const SimulatedScanSet& set,
             const std::string& dir,
             ScanSetFormat format = ScanSetFormat::Auto);

/** Whether writeScanSet writes files of this name (scanNNN.3d/.pose, NNNNNN.bin/.pcd,
 *  odometry.txt, times.txt, ground_truth.txt): an io::OutputNamePredicate. */
bool
isScanSetName(const std::string& name);

/** What simulateToDirectory wrote. */
struct ScanSetSummary {
  /** Scans and points written. */
  ///@{
  std::size_t scans = 0, points = 0;
  ///@}
  bool moving = false; ///< taken while moving (point_times): Kitti's files by default
};

/** Simulates a preset (simulatePreset) and writes it to dir (writeScanSet), as `pcl_pslam
 *  simulate` does; throws as those do. */
ScanSetSummary
simulateToDirectory(const std::string& preset,
                    const PresetOptions& options,
                    const std::string& dir,
                    ScanSetFormat format = ScanSetFormat::Auto);

} // namespace sim
} // namespace pcl_parallel
