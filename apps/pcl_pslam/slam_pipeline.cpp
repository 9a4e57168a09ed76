/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "slam_pipeline.h"

#include <pcl_parallel/slam/pipeline.h>
#include <pcl_parallel/slam/read_ahead.h>
#include <pcl_parallel/slam/segments.h>
#ifdef PCL_PARALLEL_WITH_MPI
#include <pcl_parallel/mpi/pipeline.h>
#endif

#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>

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
  result.own_end = n;
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
  std::unique_ptr<slam::Pipeline> owned;
  if (params.mpi || params.segment_size > 0) {
    const slam::SegmentProgress step =
        [&](const char* stage, std::size_t done, std::size_t total) {
          if (progress)
            progress(stage, static_cast<int>(done), static_cast<int>(total));
        };
#ifdef PCL_PARALLEL_WITH_MPI
    if (params.mpi) {
      MPI_Comm_rank(MPI_COMM_WORLD, &result.rank);
      MPI_Comm_size(MPI_COMM_WORLD, &result.ranks);
      const std::size_t ranks = static_cast<std::size_t>(result.ranks);
      const std::size_t size =
          params.segment_size > 0 ? params.segment_size : (n + ranks - 1) / ranks;
      pcl_parallel::mpi::SegmentsReport report;
      owned = pcl_parallel::mpi::mapSegments(
          MPI_COMM_WORLD, params, n, size, params.segment_overlap, source, &report, step);
      result.segments = report.segments;
      result.segment_size = size;
      std::tie(result.own_begin, result.own_end) =
          pcl_parallel::mpi::scansOfRank(n, size, result.rank, result.ranks);
      result.wait_seconds = report.wait_seconds;
      result.bytes_shared = report.bytes_shared;
      result.scans_sent = report.scans_sent;
      unsigned long kept = report.kept_scans, most = 0;
      MPI_Allreduce(&kept, &most, 1, MPI_UNSIGNED_LONG, MPI_MAX, MPI_COMM_WORLD);
      result.max_kept_scans = most;
    }
#endif
    if (!owned) {
      owned = slam::mapSegments(
          params, n, params.segment_size, params.segment_overlap, source, step);
      result.segments = (n + params.segment_size - 1) / params.segment_size;
      result.segment_size = params.segment_size;
    }
  }
  else { // the online pipeline: loop corrections feed back into the front end
    owned.reset(new slam::Pipeline(params));
    slam::ReadAhead ahead(source, n, params.num_threads); // scan i + 1 read as i is matched
    for (std::size_t i = 0; i < n; ++i) {
      const slam::SourceScan s = ahead(i);
      owned->addScan(*s.cloud, s.odometry, s.stamp, s.point_times);
      if (progress)
        progress("icp", static_cast<int>(i + 1), static_cast<int>(n));
    }
  }
  slam::Pipeline& pipeline = *owned;
  if (progress) // the last relaxation has its own line, not the next stage's time
    progress("pLUM", 0, 1);
  pipeline.finish();
  if (progress)
    progress("pLUM", 1, 1);
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
