/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "slam_pipeline.h"

#include <pcl_parallel/slam/mapping.h>

#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

namespace pcl_pslam {

Result
run(const ScanReader& read,
    std::size_t n,
    const Poses& odometry,
    const std::vector<double>& stamps,
    const pcl_parallel::slam::Parameters& params,
    const pcl_parallel::slam::MappingOptions& mapping,
    const Progress& progress)
{
  namespace slam = pcl_parallel::slam;
  if (n < 2)
    throw std::invalid_argument("pcl_pslam: needs at least 2 scans, got " + std::to_string(n));
  if (!odometry.empty() && odometry.size() != n)
    throw std::invalid_argument("pcl_pslam: " + std::to_string(odometry.size()) +
                                " initial poses for " + std::to_string(n) + " scans");
  if (!stamps.empty() && stamps.size() != n)
    throw std::invalid_argument("pcl_pslam: " + std::to_string(stamps.size()) +
                                " time stamps for " + std::to_string(n) + " scans");
  const slam::ScanSource source = [&](std::size_t i) {
    slam::SourceScan s = read(i);
    if (!s.cloud || s.cloud->empty())
      throw std::invalid_argument("pcl_pslam: scan " + std::to_string(i) + " is empty");
    if (!odometry.empty())
      s.odometry = odometry[i];
    if (!stamps.empty())
      s.stamp = stamps[i];
    return s;
  };
  Result result;
  result.mapping = mapping;
  const std::unique_ptr<slam::Pipeline> pipeline =
      slam::mapSequence(params,
                        mapping,
                        n,
                        source,
                        &result.spread,
                        [&](const char* stage, std::size_t done, std::size_t total) {
                          if (progress)
                            progress(stage, static_cast<int>(done), static_cast<int>(total));
                        });
  result.icp = pipeline->frontEndPoses();
  result.final = pipeline->poses();
  for (const auto& l : pipeline->links())
    if (l.loop)
      result.links.emplace_back(l.source, l.target);
  for (const auto& r : pipeline->reports()) {
    result.icp_failures += r.converged ? 0 : 1;
    result.lum_iterations += r.lum_iterations;
  }
  result.times = pipeline->times();
  result.reports = pipeline->reports();
  result.relaxations = pipeline->relaxations();
  result.bytes_per_scan = pipeline->bytesPerScan();
  result.parameters = pipeline->resolvedParameters();
  if (!odometry.empty())
    result.odometry_disagreement =
        slam::odometryDisagreement(result.reports, result.parameters.reduction.voxel_size);
  return result;
}

Result
run(const std::vector<Cloud::Ptr>& scans,
    const Poses& odometry,
    const pcl_parallel::slam::Parameters& params,
    const Progress& progress)
{
  const auto read = [&](std::size_t k) {
    pcl_parallel::slam::SourceScan s;
    s.cloud = scans[k];
    return s;
  };
  return run(read, scans.size(), odometry, {}, params, {}, progress);
}

} // namespace pcl_pslam
