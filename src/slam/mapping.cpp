/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/io/scan_directory.h>
#include <pcl_parallel/slam/mapping.h>
#include <pcl_parallel/slam/preprocess.h>
#include <pcl_parallel/slam/read_ahead.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

namespace pcl_parallel {
namespace slam {

std::unique_ptr<Pipeline>
mapOnline(const Parameters& params,
          std::size_t num_scans,
          const ScanSource& source,
          const SegmentProgress& progress)
{
  std::unique_ptr<Pipeline> pipeline(new Pipeline(params));
  ReadAhead ahead(source, num_scans, params.num_threads); // scan i + 1 read as i is matched
  for (std::size_t i = 0; i < num_scans; ++i) {
    const SourceScan s = ahead(i);
    pipeline->addScan(*s.cloud, s.odometry, s.stamp, s.point_times);
    if (progress)
      progress("icp", i + 1, num_scans);
  }
  return pipeline;
}

std::unique_ptr<Pipeline>
mapSequence(const Parameters& params,
            const MappingOptions& options,
            std::size_t num_scans,
            const ScanSource& source,
            MappingReport* report,
            const SegmentProgress& progress)
{
  if (num_scans == 0)
    throw std::invalid_argument("mapSequence: no scans");
  MappingReport local;
  MappingReport& out = report ? *report : local;
  out = MappingReport();
  out.own_end = num_scans;
  std::unique_ptr<Pipeline> pipeline;
  switch (options.backend) {
  case MappingBackend::kOnline:
    pipeline = mapOnline(params, num_scans, source, progress);
    break;
  case MappingBackend::kSegments:
    pipeline = mapSegments(
        params, num_scans, options.segment_size, options.segment_overlap, source, progress);
    out.segment_size = options.segment_size;
    out.segments = (num_scans + options.segment_size - 1) / options.segment_size;
    break;
  case MappingBackend::kRanks:
    pipeline = detail::mapOverRanks(params, options, num_scans, source, out, progress);
    break;
  }
  if (progress) // the last relaxation has its own step
    progress("pLUM", 0, 1);
  pipeline->finish();
  if (progress)
    progress("pLUM", 1, 1);
  return pipeline;
}

namespace {

/** The pipeline's poses, loop links and figures. */
MappingResult
collectResult(const Pipeline& pipeline, bool odometry)
{
  MappingResult result;
  result.icp = pipeline.frontEndPoses();
  result.final = pipeline.poses();
  for (const auto& l : pipeline.links())
    if (l.loop)
      result.links.emplace_back(l.source, l.target);
  for (const auto& r : pipeline.reports()) {
    result.icp_failures += r.converged ? 0 : 1;
    result.lum_iterations += r.lum_iterations;
    result.pose_searched += r.pose_searched ? 1 : 0;
    result.pose_search_won += std::isfinite(r.start_heading) ? 1 : 0;
    result.deskewed_again += r.deskewed_again ? 1 : 0;
  }
  result.times = pipeline.times();
  result.reports = pipeline.reports();
  result.relaxations = pipeline.relaxations();
  result.revisit_links = pipeline.revisitLinks();
  result.bytes_per_scan = pipeline.bytesPerScan();
  result.parameters = pipeline.resolvedParameters();
  result.consistency = pipeline.consistency();
  result.consistency_icp = pipeline.consistency(true);
  if (odometry)
    result.odometry_disagreement =
        odometryDisagreement(result.reports, result.parameters.reduction.voxel_size);
  return result;
}

} // namespace

MappingResult
mapScans(const ScanSource& read,
         std::size_t n,
         const Poses& odometry,
         const std::vector<double>& stamps,
         const Parameters& params,
         const MappingOptions& options,
         const SegmentProgress& progress)
{
  if (n < 2)
    throw std::invalid_argument("mapScans: needs at least 2 scans, got " + std::to_string(n));
  if (!odometry.empty() && odometry.size() != n)
    throw std::invalid_argument("mapScans: " + std::to_string(odometry.size()) +
                                " initial poses for " + std::to_string(n) + " scans");
  if (!stamps.empty() && stamps.size() != n)
    throw std::invalid_argument("mapScans: " + std::to_string(stamps.size()) +
                                " time stamps for " + std::to_string(n) + " scans");
  const ScanSource source = [&](std::size_t i) {
    SourceScan s = read(i);
    if (!s.cloud || s.cloud->empty())
      throw std::invalid_argument("mapScans: scan " + std::to_string(i) + " is empty");
    if (!odometry.empty())
      s.odometry = odometry[i];
    if (!stamps.empty())
      s.stamp = stamps[i];
    return s;
  };
  MappingReport spread;
  const std::unique_ptr<Pipeline> pipeline =
      mapSequence(params, options, n, source, &spread, progress);
  MappingResult result = collectResult(*pipeline, !odometry.empty());
  result.mapping = options;
  result.spread = spread;
  return result;
}

MappingResult
mapScans(const std::vector<Cloud::Ptr>& scans,
         const Poses& odometry,
         const Parameters& params,
         const SegmentProgress& progress)
{
  const auto read = [&](std::size_t k) {
    SourceScan s;
    s.cloud = scans[k];
    return s;
  };
  return mapScans(read, scans.size(), odometry, {}, params, {}, progress);
}

std::vector<std::size_t>
notableSequenceSteps(const MappingResult& r)
{
  const double cauchy = r.parameters.loops.sequence_cauchy_scale;
  const double notable = cauchy > 0.0 ? cauchy : kChi2Quantile99SixDof;
  std::vector<std::pair<double, std::size_t>> chi2;
  for (std::size_t i = 0; i < r.reports.size(); ++i)
    if (r.reports[i].sequence_chi2 > notable)
      chi2.emplace_back(r.reports[i].sequence_chi2, i);
  std::sort(chi2.rbegin(), chi2.rend());
  std::vector<std::size_t> scans;
  for (const auto& c : chi2)
    scans.push_back(c.second);
  return scans;
}

MappingResult
mapDirectory(const io::ScanDirectory& scans,
             const Parameters& params,
             const MappingOptions& options,
             const SegmentProgress& progress,
             DirectoryReading& reading)
{
  std::vector<bool> timed(scans.size(), false);
  bool looked = false;
  const ScanSource read = [&](std::size_t k) {
    const auto start = std::chrono::steady_clock::now();
    SourceScan scan;
    const bool times = params.deskew.enabled || !looked;
    looked = true;
    scan.cloud = io::readScan(scans, k, times ? &scan.point_times : nullptr);
    if (!timed[k] && spansSweep(scan.point_times)) {
      timed[k] = true;
      ++reading.timed_scans;
    }
    if (!params.deskew.enabled)
      scan.point_times.clear();
    reading.seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return scan;
  };
  Parameters p = params;
  p.planar = p.planar || scans.planar;
  return mapScans(read,
                  scans.size(),
                  scans.odometry ? scans.initial : Poses(),
                  scans.has_stamps ? scans.stamps : std::vector<double>(),
                  p,
                  options,
                  progress);
}

Cloud::Ptr
assembleMap(const io::ScanDirectory& scans,
            const Poses& poses,
            const Parameters& params,
            double voxel_size,
            const std::function<void(int, int)>& step,
            std::size_t begin,
            std::size_t end)
{
  const std::vector<double> stamps = scans.has_stamps ? scans.stamps : std::vector<double>();
  const MapScanSource read = [&](std::size_t k, unsigned threads) -> Cloud::ConstPtr {
    if (!params.deskew.enabled)
      return io::readScan(scans, k);
    std::vector<double> point_times;
    const Cloud::Ptr scan = io::readScan(scans, k, &point_times);
    Parameters p = params;
    p.num_threads = threads;
    return mapFrame(*scan, point_times, poses, stamps, k, p);
  };
  return assembleMap(
      read, poses, begin, std::min(end, scans.size()), voxel_size, params.num_threads, step);
}

} // namespace slam
} // namespace pcl_parallel
