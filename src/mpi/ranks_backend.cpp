/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * slam::mapSequence's kRanks backend, built with MPI (no_ranks_backend.cpp without).
 */
#include <pcl_parallel/mpi/pipeline.h>
#include <pcl_parallel/slam/mapping.h>

#include <tuple>

namespace pcl_parallel {
namespace slam {
namespace detail {

std::unique_ptr<Pipeline>
mapOverRanks(const Parameters& params,
             const MappingOptions& options,
             std::size_t num_scans,
             const ScanSource& source,
             MappingReport& report,
             const SegmentProgress& progress)
{
  MPI_Comm_rank(MPI_COMM_WORLD, &report.rank);
  MPI_Comm_size(MPI_COMM_WORLD, &report.ranks);
  const std::size_t ranks = static_cast<std::size_t>(report.ranks);
  const std::size_t size =
      options.segment_size > 0 ? options.segment_size : (num_scans + ranks - 1) / ranks;
  mpi::SegmentsReport segments;
  std::unique_ptr<Pipeline> pipeline = mpi::mapSegments(MPI_COMM_WORLD,
                                                        params,
                                                        num_scans,
                                                        size,
                                                        options.segment_overlap,
                                                        source,
                                                        &segments,
                                                        progress);
  report.segments = segments.segments;
  report.segment_size = size;
  std::tie(report.own_begin, report.own_end) =
      mpi::scansOfRank(num_scans, size, report.rank, report.ranks);
  report.wait_seconds = segments.wait_seconds;
  report.bytes_shared = segments.bytes_shared;
  report.scans_sent = segments.scans_sent;
  unsigned long kept = segments.kept_scans, most = 0;
  MPI_Allreduce(&kept, &most, 1, MPI_UNSIGNED_LONG, MPI_MAX, MPI_COMM_WORLD);
  report.max_kept_scans = most;
  return pipeline;
}

} // namespace detail
} // namespace slam
} // namespace pcl_parallel
