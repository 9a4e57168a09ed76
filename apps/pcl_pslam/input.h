/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pcl_pslam's input: a directory of scans (io::openScanDirectory) or a simulated preset
 * written as one, and the notes about them.
 */
#pragma once

#include "options.h"

#include <pcl_parallel/io/output_directory.h>
#include <pcl_parallel/io/scan_directory.h>

#include <memory>
#include <string>

namespace pcl_pslam {

/** What `run` reads (the scans one at a time, as the pipeline takes them). */
struct Input : pcl_parallel::io::ScanDirectory {
  Poses truth;                                  ///< the simulation's truth (demo), else empty
  pcl_parallel::slam::DirectoryReading reading; ///< by this rank
};

/** io::openScanDirectory(o) (an --out that is the scan directory is refused before, as
 *  one holding files no run wrote). Throws UsageError for a request that cannot be met,
 *  DataError naming the file for bad data. */
Input
openDirectory(const Options& o);

/** `demo`'s simulated scans: where, and whether taken while moving (KITTI-like: raw
 *  sweeps with odometry.txt beside). */
struct DemoScans {
  std::string dir;
  bool moving = false;
  std::shared_ptr<pcl_parallel::io::TemporaryDirectory> temporary; ///< without --keep
};

/** `demo`: writes o.preset to o.keep (one unit, io::OutputDirectory) or to an
 *  io::TemporaryDirectory. */
DemoScans
simulateDemo(const Options& o);

/** Points o.dir at the demo's scans and sets o.deskew for sweeps taken while moving. */
void
useDemoScans(Options& o, const DemoScans& scans);

} // namespace pcl_pslam
