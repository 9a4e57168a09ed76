/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/slam/mapping.h>
#include <pcl_parallel/slam/read_ahead.h>

#include <stdexcept>

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

} // namespace slam
} // namespace pcl_parallel
