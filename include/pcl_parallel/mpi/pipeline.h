/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/mpi/distributed_lum.h>
#include <pcl_parallel/slam/segments.h>

#include <cstdint>
#include <functional>
#include <memory>

namespace pcl_parallel {
namespace mpi {

/** pLUM for slam::LoopCloser / slam::Pipeline (setRelaxation) over the ranks of `comm`:
 *  DistributedLUM::computeOn on the graph every rank holds. Collective in each relax();
 *  the poses are bit-identical to ParallelLUM::compute for any rank count. */
slam::LoopCloser::Relaxation
relaxOverRanks(MPI_Comm comm);

/** The scans [first, second) whose segments rank `rank` of `size` matches in
 *  mapSegments (its own scans, without the overlap; empty for a rank without a segment). */
std::pair<std::size_t, std::size_t>
scansOfRank(std::size_t num_scans, std::size_t segment_size, int rank, int size);

/** Where mapSegments spent its time on this rank, and what it sent. */
struct SegmentsReport {
  std::size_t segments = 0;       ///< of the sequence
  std::size_t own_segments = 0;   ///< matched on this rank
  std::size_t own_scans = 0;      ///< ... with this many own scans (without the overlap)
  double front_end_seconds = 0.0; ///< this rank's front ends
  double wait_seconds = 0.0;      ///< waiting for the other ranks' front ends
  std::uint64_t bytes_shared = 0; ///< matched scans sent to the other ranks, all ranks
};

/**
 * \brief The mapping pipeline over the ranks of `comm` (issue 12; docs/design.md,
 * "Segments"): the sequence is cut into segments of `segment_size` scans (slam::
 * splitSequence, `overlap` scans shared with the previous one), contiguous blocks of
 * segments go to the ranks (linkRange), each rank reads and matches only its segments'
 * scans, then every rank receives every matched scan, in order, and runs the same loop
 * closing over the whole sequence with pLUM spread over the ranks (relaxOverRanks).
 *
 * Collective. The lengths come from scan 0 on rank 0 (slam::sequenceMedianRange),
 * broadcast. Every rank returns the same pipeline (finish() is left to the caller):
 * poses, links and kept scans bit-identical to slam::mapSegments with the same segment
 * size in one process, for any rank and thread count. Errors (a scan a rank cannot read,
 * different options or inputs on different ranks) are thrown on every rank as one
 * CollectiveError composed on rank 0 (throwIfAnyFailed, requireSameOnAllRanks).
 * `progress` is called on each rank after each scan its front ends match ("match",
 * done, this rank's total), then after each scan joined into the graph ("join", done,
 * num_scans).
 */
std::unique_ptr<slam::Pipeline>
mapSegments(MPI_Comm comm,
            const slam::Parameters& params,
            std::size_t num_scans,
            std::size_t segment_size,
            std::size_t overlap,
            const slam::ScanSource& read,
            SegmentsReport* report = nullptr,
            const slam::SegmentProgress& progress = {});

} // namespace mpi
} // namespace pcl_parallel
