/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "input.h"

#include <pcl_parallel/io/output_directory.h>
#include <pcl_parallel/sim/scan_set_writer.h>

#include <algorithm>
#include <memory>

namespace pcl_pslam {

Input
openDirectory(const Options& o)
{
  Input in;
  try {
    static_cast<pcl_parallel::io::ScanDirectory&>(in) = pcl_parallel::io::openScanDirectory(o);
  }
  catch (const pcl_parallel::io::ScanDirectoryUsageError& e) {
    throw UsageError(e.what());
  }
  return in;
}

DemoScans
simulateDemo(const Options& o)
{
  namespace io = pcl_parallel::io;
  const auto names = pcl_parallel::sim::presetNames();
  if (std::find(names.begin(), names.end(), o.preset) == names.end())
    throw UsageError("--preset: unknown preset '" + o.preset + "' (pcl_pslam simulate --list)");
  pcl_parallel::sim::PresetOptions options;
  options.num_threads = o.threads;
  DemoScans scans;
  if (o.keep.empty()) {
    scans.temporary = std::make_shared<io::TemporaryDirectory>("pcl_pslam_demo-");
    scans.dir = scans.temporary->path();
    scans.moving = pcl_parallel::sim::simulateToDirectory(o.preset, options, scans.dir).moving;
    return scans;
  }
  std::unique_ptr<io::OutputDirectory> keep;
  try {
    keep = std::make_unique<io::OutputDirectory>(o.keep, pcl_parallel::sim::isScanSetName);
  }
  catch (const io::OutputDirectoryError& e) {
    throw UsageError(std::string("--keep ") + e.what());
  }
  scans.moving = pcl_parallel::sim::simulateToDirectory(o.preset, options, keep->path()).moving;
  keep->commit();
  scans.dir = keep->target();
  return scans;
}

void
useDemoScans(Options& o, const DemoScans& scans)
{
  o.dir = scans.dir; // a KITTI-like set's odometry.txt beside: openScanDirectory's default
  o.deskew = o.deskew || scans.moving; // raw sweeps
}

} // namespace pcl_pslam
