/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * A whole sequence mapped by one of three backends, siblings with one face: the online
 * pipeline (mapOnline), segments in this process (segments.h) and segments over MPI
 * ranks (mpi/pipeline.h). The results are bit-identical for any thread count, and the
 * two segmented backends for any rank count.
 */
#pragma once

#include <pcl_parallel/slam/pipeline.h>
#include <pcl_parallel/slam/segments.h>

#include <cstddef>
#include <cstdint>
#include <memory>

namespace pcl_parallel {
namespace slam {

enum class MappingBackend {
  kOnline,   ///< scan by scan; loop corrections feed back into the front end
  kSegments, ///< the segments' front ends in turn, then loop closing over all
  kRanks,    ///< the segments over the ranks of MPI_COMM_WORLD (MPI initialised)
};

/** How a sequence is cut and spread. */
struct MappingOptions {
  MappingBackend backend = MappingBackend::kOnline;
  /** Scans per segment (kSegments, kRanks); 0 with kRanks: the scans over the ranks. */
  std::size_t segment_size = 0;
  std::size_t segment_overlap = 5; ///< scans a segment shares with the one before
};

/** What the backend did beside the pipeline's own figures. */
struct MappingReport {
  std::size_t segments = 0, segment_size = 0; ///< segmented backends
  /** The scans [own_begin, own_end) this process matched (all of them in one process). */
  std::size_t own_begin = 0, own_end = 0;
  int rank = 0, ranks = 1;
  double wait_seconds = 0.0;      ///< waiting for the other ranks' front ends
  std::uint64_t bytes_shared = 0; ///< sent between ranks outside pLUM
  std::size_t scans_sent = 0;     ///< scans sent to the rank of a link to them
  std::size_t max_kept_scans = 0; ///< the most scans whose points one rank keeps
};

/** Maps scans [0, num_scans) read from `source` with options.backend, then finish()
 *  (collective with kRanks). `progress`: the backend's steps ("icp" per scan online,
 *  "match" and "join" segmented), then ("pLUM", 0, 1) and ("pLUM", 1, 1) around the
 *  final relaxation. Throws std::invalid_argument for no scans; kRanks throws
 *  std::runtime_error where the library was built without MPI. */
std::unique_ptr<Pipeline>
mapSequence(const Parameters& params,
            const MappingOptions& options,
            std::size_t num_scans,
            const ScanSource& source,
            MappingReport* report = nullptr,
            const SegmentProgress& progress = {});

/** The online backend: every scan through Pipeline::addScan, the next one read while one
 *  is matched (ReadAhead); finish() is left to the caller. */
std::unique_ptr<Pipeline>
mapOnline(const Parameters& params,
          std::size_t num_scans,
          const ScanSource& source,
          const SegmentProgress& progress = {});

namespace detail {
/** kRanks: mpi::mapSegments over MPI_COMM_WORLD (src/mpi/ranks_backend.cpp), or a
 *  std::runtime_error without MPI (src/mpi/no_ranks_backend.cpp). */
std::unique_ptr<Pipeline>
mapOverRanks(const Parameters& params,
             const MappingOptions& options,
             std::size_t num_scans,
             const ScanSource& source,
             MappingReport& report,
             const SegmentProgress& progress);
} // namespace detail

} // namespace slam
} // namespace pcl_parallel
