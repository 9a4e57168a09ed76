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
#include <string>
#include <vector>

namespace pcl_parallel {
namespace mpi {

/**
 * \brief slam::ScanExchange over the ranks of `comm` (slam::LoopCloser::setExchange,
 * slam::Pipeline::setExchange): scan i's points are kept by rank owner(i); a scan goes
 * point to point to the rank that measures a link to it, a loop check's sample is
 * broadcast, and pLUM runs as DistributedLUM::computeOn with each link measured by the
 * owner of its source scan. Poses bit-identical to one process for any rank count.
 */
class RankExchange : public slam::ScanExchange {
public:
  /** owner(i): the rank that keeps scan i (the same function on every rank). */
  RankExchange(MPI_Comm comm, std::function<int(std::size_t scan)> owner);

  int
  rank() const override
  {
    return rank_;
  }
  int
  owner(std::size_t scan) const override
  {
    return owner_(scan);
  }
  void
  broadcast(int root, std::vector<double>& values) override;
  void
  maximum(std::vector<double>& values) override;
  void
  send(int from, int to, slam::KeptScan& scan) override;
  void
  relax(ParallelLUM<slam::PointT>& lum) override;

  /** Payload bytes this rank sent (scans, samples and results; not pLUM's). */
  std::uint64_t
  bytesSent() const
  {
    return bytes_sent_;
  }
  /** Scans sent point to point by this rank. */
  std::size_t
  scansSent() const
  {
    return scans_sent_;
  }

private:
  MPI_Comm comm_;
  int rank_ = 0;
  int size_ = 1;
  std::function<int(std::size_t)> owner_;
  std::vector<std::string> reasons_; ///< of links dropped on other ranks (pLUM points there)
  std::uint64_t bytes_sent_ = 0;
  std::size_t scans_sent_ = 0;
};

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
  /** Bytes sent between ranks outside pLUM, all ranks: the matched scans' poses and
   *  reports to every rank, scans to the rank of a link to them, loop-check samples. */
  std::uint64_t bytes_shared = 0;
  std::size_t scans_sent = 0; ///< scans sent point to point, all ranks
  /** Scans whose reduced points this rank keeps: its own and those its links need. */
  std::size_t kept_scans = 0;
  std::uint64_t lum_bytes_per_iteration = 0; ///< pLUM's, all ranks, on the whole graph
};

/**
 * \brief The mapping pipeline over the ranks of `comm` (issue 12; docs/design.md,
 * "Segments"): the sequence is cut into segments of `segment_size` scans (slam::
 * splitSequence, `overlap` scans shared with the previous one), contiguous blocks of
 * segments go to the ranks (linkRange), each rank reads and matches only its segments'
 * scans and keeps their reduced points; every rank receives every matched scan's step
 * and report, in order, and runs the same loop closing over the whole sequence, with the
 * scans spread (RankExchange): a rank never holds the whole survey.
 *
 * Collective. The lengths come from scan 0 on rank 0 (slam::sequenceMedianRange),
 * broadcast. Every rank returns the same pipeline (finish() is left to the caller, and
 * collective): poses, links and reports bit-identical to slam::mapSegments with the same
 * segment size in one process, for any rank and thread count; reducedScan() and map()
 * give this rank's own scans (scansOfRank). Errors (a scan a rank cannot read,
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
