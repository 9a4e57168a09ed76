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
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace pcl_parallel {
namespace io {
struct ScanDirectory;
}
namespace slam {

/** How a sequence is mapped: one online pipeline, segments in one process, or segments over MPI
 *  ranks. */
enum class MappingBackend {
  kOnline,   ///< scan by scan; loop corrections feed back into the front end
  kSegments, ///< the segments' front ends in turn, then loop closing over all
  kRanks,    ///< the segments over the ranks of MPI_COMM_WORLD (MPI initialised)
};

/** How a sequence is cut and spread. */
struct MappingOptions {
  /** The backend. */
  MappingBackend backend = MappingBackend::kOnline;
  /** Scans per segment (kSegments, kRanks); 0 with kRanks: the scans over the ranks. */
  std::size_t segment_size = 0;
  std::size_t segment_overlap = 5; ///< scans a segment shares with the one before
};

/** What the backend did beside the pipeline's own figures. */
struct MappingReport {
  /** Segments and their size. */
  std::size_t segments = 0, segment_size = 0; ///< segmented backends
  ///@{
  /** The scans [own_begin, own_end) this process matched (all of them in one process). */
  std::size_t own_begin = 0, own_end = 0;
  ///@}
  /** This process's rank and the number of ranks. */
  ///@{
  int rank = 0, ranks = 1;
  ///@}
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

/** A sequence as mapScans leaves it: the poses, the loop links and what the run reports. */
struct MappingResult {
  Poses icp;                                                  ///< the front end's poses
  Poses final;                                                ///< after the last pLUM
  std::vector<std::pair<std::uint32_t, std::uint32_t>> links; ///< loop links (source, target)
  int icp_failures = 0; ///< matches that did not converge (their initial step kept)
  /** pLUM iterations of the last relaxation. */
  int lum_iterations = 0;
  std::size_t pose_searched = 0;   ///< matches the pose search ran for
  std::size_t pose_search_won = 0; ///< matches it placed
  std::size_t deskewed_again = 0;  ///< scans deskewed again after their match
  /** Time per stage. */
  StageTimes times;
  std::vector<ScanReport> reports; ///< per scan
  int relaxations = 0;             ///< pLUM runs
  std::size_t revisit_links = 0;   ///< Pipeline::revisitLinks()
  /** With odometry: odometryDisagreement (none: too few steps, or too short). */
  std::optional<double> odometry_disagreement;
  /** Where the scanner came back: revisitConsistency of the final poses, and of the front
   *  end's (what loop closing started from). */
  RevisitConsistency consistency, consistency_icp;
  std::size_t bytes_per_scan = 0; ///< kept by the pipeline
  Parameters parameters;          ///< as resolved (lengths in m)
  MappingOptions mapping;         ///< how the sequence was spread
  MappingReport spread;           ///< what the backend did
};

/** mapSequence over scans 0..n-1 of `read`, each given its pose of `odometry` (a pose per
 *  scan, the first kept fixed; empty: constant velocity from the identity) and its time of
 *  `stamps` (s; or none), then the pipeline's figures. Throws std::invalid_argument for
 *  fewer than 2 scans, mismatched sizes, an empty scan or non-finite poses. */
MappingResult
mapScans(const ScanSource& read,
         std::size_t n,
         const Poses& odometry,
         const std::vector<double>& stamps,
         const Parameters& params,
         const MappingOptions& options = {},
         const SegmentProgress& progress = {});

/** The same over scans in memory, online, without stamps. */
MappingResult
mapScans(const std::vector<Cloud::Ptr>& scans,
         const Poses& odometry,
         const Parameters& params,
         const SegmentProgress& progress = {});

/** The loop links: result.links between scans that are not neighbours, in their order. */
std::vector<std::pair<std::uint32_t, std::uint32_t>>
loopLinks(const MappingResult& result);

/** The scans whose step from their predecessor the final poses contradict most, worst
 *  first: ScanReport::sequence_chi2 beyond the loop closing's Cauchy scale where it has
 *  one, else beyond kChi2Quantile99SixDof. The first places to look at in a map. */
std::vector<std::size_t>
notableSequenceSteps(const MappingResult& result);

/** What mapDirectory's reading saw. */
struct DirectoryReading {
  /** Scans whose per-point times span a sweep, each counted once (a segment reads its
   *  overlap again). */
  std::size_t timed_scans = 0;
  double seconds = 0.0; ///< spent reading
};

/** mapScans over a directory's scans, each read (io::readScan) when the pipeline takes it,
 *  with the directory's odometry and time stamps where it has them, planar for 2D scans
 *  (io::ScanDirectory::planar). Per-point times are
 *  read with params.deskew; without it the first scan's only, so that `reading` tells the
 *  caller whether the scans carry them. */
MappingResult
mapDirectory(const io::ScanDirectory& scans,
             const Parameters& params,
             const MappingOptions& options,
             const SegmentProgress& progress,
             DirectoryReading& reading);

/** A mapped directory as JSON text (`pcl_pslam`'s report.json less what only the app knows):
 *  "parameters" (as resolved, lengths in m), "pipeline_seconds" (reading included),
 *  "bytes_kept_per_scan", "relaxations", "scans" (per scan: its number, stamp and file, what
 *  the front end did, the loops tried), "icp", "loops" (the links between scans that are
 *  not neighbours), "links", "lum" and, segmented, "segments". Indented by `indent` spaces
 *  (-1: one line); bytes of names that are not UTF-8 become U+FFFD. */
std::string
toJson(const MappingResult& result,
       const io::ScanDirectory& scans,
       const DirectoryReading& reading,
       int indent = -1);

/** The merged map (assembleMap) of a directory's scans [begin, end) at `poses`: each read
 *  again at full resolution (io::readScan) and, with params.deskew, deskewed by the motion
 *  at its pose (mapFrame), on params.num_threads threads. */
Cloud::Ptr
assembleMap(const io::ScanDirectory& scans,
            const Poses& poses,
            const Parameters& params,
            double voxel_size,
            const std::function<void(int, int)>& step = {},
            std::size_t begin = 0,
            std::size_t end = std::size_t(-1));

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
