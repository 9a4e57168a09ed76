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
    const Poses& initial,
    const Parameters& params,
    const Progress& progress)
{
  if (n < 2)
    throw std::invalid_argument("pcl_pslam: needs at least 2 scans, got " + std::to_string(n));
  if (initial.size() != n)
    throw std::invalid_argument("pcl_pslam: " + std::to_string(initial.size()) +
                                " initial poses for " + std::to_string(n) + " scans");
  namespace slam = pcl_parallel::slam;
  Result result;
  if (!params.stamps.empty() && params.stamps.size() != n)
    throw std::invalid_argument("pcl_pslam: " + std::to_string(params.stamps.size()) +
                                " time stamps for " + std::to_string(n) + " scans");
  const slam::ScanSource source = [&](std::size_t i) {
    slam::SourceScan s = read(i);
    if (!s.cloud || s.cloud->empty())
      throw std::invalid_argument("pcl_pslam: scan " + std::to_string(i) + " is empty");
    if (params.odometry)
      s.odometry = initial[i];
    if (!params.stamps.empty())
      s.stamp = params.stamps[i];
    return s;
  };
  slam::MappingOptions mapping;
  mapping.backend = params.mpi                ? slam::MappingBackend::kRanks
                    : params.segment_size > 0 ? slam::MappingBackend::kSegments
                                              : slam::MappingBackend::kOnline;
  mapping.segment_size = params.segment_size;
  mapping.segment_overlap = params.segment_overlap;
  slam::MappingReport report;
  const std::unique_ptr<slam::Pipeline> owned =
      slam::mapSequence(params,
                        mapping,
                        n,
                        source,
                        &report,
                        [&](const char* stage, std::size_t done, std::size_t total) {
                          if (progress)
                            progress(stage, static_cast<int>(done), static_cast<int>(total));
                        });
  const slam::Pipeline& pipeline = *owned;
  result.segments = report.segments;
  result.segment_size = report.segment_size;
  result.own_begin = report.own_begin;
  result.own_end = report.own_end;
  result.rank = report.rank;
  result.ranks = report.ranks;
  result.wait_seconds = report.wait_seconds;
  result.bytes_shared = report.bytes_shared;
  result.scans_sent = report.scans_sent;
  result.max_kept_scans = report.max_kept_scans;
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
  if (params.odometry)
    result.odometry_disagreement =
        slam::odometryDisagreement(result.reports, result.front_end.voxel_size);
  result.loop_closure = pipeline.loopClosureParameters();
  return result;
}

Result
run(const std::vector<Cloud::Ptr>& scans,
    const Poses& initial,
    const Parameters& params,
    const Progress& progress)
{
  const auto read = [&](std::size_t k) {
    pcl_parallel::slam::SourceScan s;
    s.cloud = scans[k];
    return s;
  };
  return run(read, scans.size(), initial, params, progress);
}

} // namespace pcl_pslam
