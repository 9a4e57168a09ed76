/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "slam_pipeline.h"

#include <pcl_parallel/slam/pipeline.h>

#include <optional>
#include <stdexcept>
#include <string>

namespace pcl_pslam {

Result
run(const ScanReader& read,
    std::size_t n,
    const Poses& initial,
    const Parameters& params,
    const Progress& progress)
{
  if (n < 2)
    throw std::invalid_argument("pcl_pslam: needs at least 2 scans, got " + std::to_string(n));
  if (initial.size() != n)
    throw std::invalid_argument("pcl_pslam: " + std::to_string(initial.size()) +
                                " initial poses for " + std::to_string(n) + " scans");
  pcl_parallel::slam::Pipeline pipeline(params);
  for (std::size_t i = 0; i < n; ++i) {
    const Cloud::Ptr scan = read(i);
    if (!scan || scan->empty())
      throw std::invalid_argument("pcl_pslam: scan " + std::to_string(i) + " is empty");
    pipeline.addScan(
        *scan, params.odometry ? std::optional<Eigen::Matrix4d>(initial[i]) : std::nullopt);
    if (progress)
      progress("icp", static_cast<int>(i + 1), static_cast<int>(n));
  }
  pipeline.finish();
  Result result;
  result.icp = pipeline.frontEndPoses();
  result.final = pipeline.poses();
  for (const auto& l : pipeline.links())
    if (l.loop)
      result.links.emplace_back(l.source, l.target);
  for (const auto& r : pipeline.reports()) {
    result.icp_failures += r.converged ? 0 : 1;
    result.lum_iterations += r.lum_iterations;
  }
  result.times = pipeline.times();
  result.reports = pipeline.reports();
  result.relaxations = pipeline.relaxations();
  result.bytes_per_scan = pipeline.bytesPerScan();
  result.front_end = pipeline.frontEndParameters();
  result.loop_closure = pipeline.loopClosureParameters();
  return result;
}

Result
run(const std::vector<Cloud::Ptr>& scans,
    const Poses& initial,
    const Parameters& params,
    const Progress& progress)
{
  return run([&](std::size_t k) { return scans[k]; }, scans.size(), initial, params, progress);
}

} // namespace pcl_pslam
