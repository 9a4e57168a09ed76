/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "input.h"

#include <pcl_parallel/io/output_directory.h>
#include <pcl_parallel/sim/scan_set_writer.h>
#include <pcl_parallel/slam/preprocess.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <memory>

namespace fs = std::filesystem;

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

std::string
deskewNote(const Input& in, bool deskew)
{
  if (!deskew)
    return in.reading.timed_scans == 0
               ? ""
               : "the scans carry per-point times: --deskew would deskew each "
                 "point by its own (unless they are motion-compensated already)";
  if (in.reading.timed_scans == in.size())
    return "deskewed by the points' time field";
  if (in.reading.timed_scans == 0)
    return "deskewed by azimuth (no per-point times in the scans)";
  return "deskewed by the points' time field in " + std::to_string(in.reading.timed_scans) +
         " of " + std::to_string(in.size()) + " scans, else by azimuth";
}

std::string
keyframeWarning(const Input& in, bool deskew, double sweep_period)
{
  if (!deskew || sweep_period > 0.0 || !in.has_stamps || in.stamps.size() < 2)
    return "";
  std::vector<double> gaps;
  for (std::size_t k = 1; k < in.stamps.size(); ++k)
    gaps.push_back(in.stamps[k] - in.stamps[k - 1]);
  const double gap = pcl_parallel::slam::median(gaps);
  if (!(gap > kMaxSweepSeconds))
    return "";
  char text[320];
  std::snprintf(text,
                sizeof text,
                "the scans are a median %.2f s apart, longer than a LiDAR sweep: if they are "
                "keyframes, --deskew bends each by its whole step; give the sweep's period "
                "(--sweep-period 0.1 for a 10 Hz LiDAR)",
                gap);
  return text;
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
  o.dir = scans.dir;
  if (scans.moving) { // KITTI-like: odometry.txt beside, raw sweeps
    if (!o.no_poses)
      o.poses_file = (fs::path(scans.dir) / "odometry.txt").string();
    o.deskew = true;
  }
}

} // namespace pcl_pslam
