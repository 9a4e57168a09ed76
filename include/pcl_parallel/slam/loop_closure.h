/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/parameters.h>
#include <pcl_parallel/slam/types.h>

#include <cmath>
#include <memory>
#include <vector>

namespace pcl_parallel {
template <typename PointT>
class ParallelLUM;

namespace slam {

/** chi2's 99 % quantile for 6 degrees of freedom: the gate for a pose error measured in
 *  its information (16.8119). */
constexpr double kChi2Quantile99SixDof = 16.812;

/** The largest share of either scan's points that may lie in the space the other saw
 *  through (mutualConflicts) for two scans to agree: people walking by, doors. A match
 *  shifted along a corridor or into the next room of one size, or a doubled wall, puts
 *  walls there. 2D loop links are kept only below it. */
constexpr double kMaxLoopConflicts = 0.05;

/** 2D loop search (LoopCloser::searchPair): headings within this of the poses' (30 deg),
 *  and the distinct candidates refined. */
constexpr double kMaxLoopSearchTurn = M_PI / 6.0;
constexpr std::size_t kLoopSearchCandidates = 4;

/** A loop link that was tried, and what became of it. */
struct LoopCandidate {
  /** The candidate link. */
  Link link;
  double overlap = 0.0; ///< after matching
  /** True when the link was kept. */
  bool accepted = false;
  /** How far matching moved the newer scan from where its pose put it: translation plus
   *  the rotation's displacement at the scans' median range (KISS-ICP's model error). */
  double error = 0.0;
  bool distributed = false; ///< the error was spread along the loop (the poses moved)
  /** 2D: the match came from the window search (pICP from the poses fell short). */
  bool searched = false;
};

/** A reduced scan as the loop closer keeps it: points (scanner frame) and their normals
 *  (empty: pLUM estimates them). */
struct KeptScan {
  /** The reduced points (scanner frame). */
  Cloud::ConstPtr points;
  /** Their normals. */
  std::vector<Eigen::Vector3f> normals;
};

/**
 * \brief How a LoopCloser's scans are spread over processes (docs/design.md, "The graph
 * over ranks"; mpi::RankExchange). Every process holds the whole pose graph (poses,
 * links, constraints); a scan's points are kept by its owner and by the processes that
 * measure a link to it. Every process makes the same calls in the same order (they are
 * collective), and the results are bit-identical to one process that keeps every scan.
 */
class ScanExchange {
public:
  virtual ~ScanExchange() = default;
  /** This process. */
  virtual int
  rank() const = 0;
  /** The process that keeps scan i's points (and matches its loops). */
  virtual int
  owner(std::size_t scan) const = 0;
  /** Collective: the values of process `root` on every process. */
  virtual void
  broadcast(int root, std::vector<double>& values) = 0;
  /** Collective: the element-wise maximum of every process's values (of one length). */
  virtual void
  maximum(std::vector<double>& values) = 0;
  /** Collective: `scan` of process `from` into `scan` of process `to` (from != to); the
   *  other processes pass and get nothing. */
  virtual void
  send(int from, int to, KeptScan& scan) = 0;
  /** Collective: pLUM on a graph that is the same on every process; each measures the
   *  links whose source scan it owns (it holds both scans of those). */
  virtual void
  relax(ParallelLUM<PointT>& lum) = 0;
};

/**
 * \brief The pose graph and its loop closing (paper Sec. III, V, VI-C): scans are added
 * as the front end matches them (each linked to its predecessor); detect() links the
 * newest scan to one earlier candidate (loopCandidates), keeping the link only if the
 * pair, matched with pICP, overlaps by `min_overlap` and the correction is explainable
 * by drift along the graph (`max_drift`, loopPath), and only one per
 * `min_separation / 2` scans (so a scanner that
 * lingers makes a graph linear in the scans, not quadratic); relax() runs pLUM over the
 * whole graph. Keeps each scan's reduced points with a k-d tree (bytesPerScan()).
 */
class LoopCloser {
public:
  /** From resolved parameters (resolve): loops, median_range, the reduction's source
   *  voxel (the loop pICP's sample) and num_threads. Throws std::invalid_argument for
   *  unresolved ones. */
  explicit LoopCloser(const Parameters& resolved);
  ~LoopCloser();

  /** Spreads the scans over processes (before the first addScan); null: all kept here. */
  void
  setExchange(std::shared_ptr<ScanExchange> exchange);

  /** Adds the next scan (reduced, scanner frame) at its front-end pose, with its points'
   *  normals if the front end has them (ReducedScan::normals; pLUM estimates them
   *  otherwise, from the reduced points), and the information of its match from that
   *  many pairs (ScanRecord::information, information_pairs; zero: none) against a
   *  map of `information_scans` scans in effect (ScanReport::map_scans), which
   *  with sequence_constraints holds its pose relative to the previous scan, and its
   *  k-d tree if the front end built it (ReducedScan::tree; pLUM builds it otherwise).
   *  With an exchange, a scan another process owns comes as null with its `num_points`.
   *  Collective with an exchange, as detect() and relax(). */
  void
  addScan(const Cloud::ConstPtr& scan,
          const Pose& pose,
          std::vector<Eigen::Vector3f> normals = {},
          const Information& information = Information::Zero(),
          double information_pairs = 0.0,
          double information_scans = 1.0,
          std::size_t num_points = 0,
          std::shared_ptr<const KdTreeIndex> tree = nullptr);

  /** Looks for loop links of the newest scan; adds the accepted ones to the graph and,
   *  with distribute_error and an error above overlap_distance, moves the poses since
   *  the loop's start to close it. 2D scans: where no candidate overlaps at the poses,
   *  the nearest is matched, and a match pICP does not find from the poses is searched
   *  for (searchPair). Returns every pair tried. */
  std::vector<LoopCandidate>
  detect();

  /** Links the loops the run's poses hid (LoopClosureParameters::revisit_rounds): each
   *  scan j paired with its nearest loopCandidates scan i, where the pair has no loop link
   *  and conflicts at the current poses (mutualConflicts above kMaxLoopConflicts, as
   *  revisitConsistency counts it), is matched again from those poses (2D: searched as in
   *  detect()) and linked where detect() would accept the match. Returns the links
   *  added; relax() then. */
  std::size_t
  linkRevisits();

  /** pLUM over the whole graph from the current poses, at most max_iterations (<= 0:
   *  lum_iterations) iterations; returns the iterations run. */
  int
  relax(int max_iterations = 0);

  /** Number of scans in the graph. */
  std::size_t
  size() const
  {
    return poses_.size();
  }
  /** The current poses. */
  const Poses&
  poses() const
  {
    return poses_;
  }
  /** The graph's links. */
  const std::vector<Link>&
  links() const
  {
    return links_;
  }
  /** A scan's reduced points; null where another process owns it. */
  const Cloud::ConstPtr&
  scan(std::size_t i) const
  {
    return scans_[i];
  }
  /** Scans whose points this process keeps: its own and those its links need. */
  std::size_t
  keptScans() const;
  /** Per scan, the squared Mahalanobis error of its sequence constraint at the current
   *  poses, in its own information (after relax(): how far loop closing moved the scan
   *  from the front end's step); -1 where it has none (the first scan, a failed match). */
  std::vector<double>
  sequenceChi2() const;

  /** Bytes this process holds per scan of the graph (reduced points, their k-d trees and
   *  normals). */
  std::size_t
  bytesPerScan() const;

private:
  struct Impl;

  /** The owner of scan i, or this process without an exchange. */
  int
  owner(std::size_t i) const;
  bool
  owns(std::size_t i) const;
  /** Overlap of 256-511 evenly spaced points of the newest scan (every size/256-th) with
   *  each candidate at the current poses, within twice the overlap distance, computed
   *  where the candidate is kept. */
  std::vector<double>
  firstLook(const std::vector<std::uint32_t>& candidates);
  /** pICP of scan j (default: the newest) against scan i where j is kept: converged
   *  (0/1), the measured pose of j in i's frame (16), the overlap, (2D) the conflicts and
   *  whether it was searched (0/1), on every process. `if_conflicting`: only where the pair
   *  conflicts at the current poses (else not converged). `search_within` > 0 (2D, the
   *  pair's allowedCorrection): where pICP from the poses is not accepted, searchPair. */
  std::vector<double>
  matchPair(std::uint32_t i,
            std::size_t j = kNewest,
            bool if_conflicting = false,
            double search_within = 0.0);
  static constexpr std::size_t kNewest = ~std::size_t{0};
  static constexpr std::size_t kMatchSize = 20;
  /** pICP of `sample` (of scan j) against scan i's `target` from `start`: matchPair's
   *  result, here. */
  std::vector<double>
  alignPair(std::uint32_t i,
            std::size_t j,
            const Cloud::ConstPtr& sample,
            const Cloud::ConstPtr& target,
            const Pose& start);
  /** A correlative search about the poses' `guess` (window: the `allowed` correction, at
   *  most the loop distance), each candidate matched by pICP; the match if exactly one
   *  distinct pose is accepted. */
  std::vector<double>
  searchPair(std::uint32_t i,
             std::size_t j,
             const Cloud::ConstPtr& sample,
             const Cloud::ConstPtr& target,
             const Pose& guess,
             double allowed);
  /** The largest correction of a loop between scans i and j that drift explains, at the
   *  current poses and links: max_drift times their loopPath (a loop link as long as the
   *  drift that misplaces a scan by pLUM's first gate, lum_distance / max_drift), at
   *  least 2 overlap distances. One per pair: a search's candidates share it. */
  double
  allowedCorrection(std::size_t i, std::size_t j) const;
  /** Whether a match (matchPair's) of scan j to scan i is kept as a loop link: overlap,
   *  a correction within `allowed` (allowedCorrection), (2D) no conflicts; `error`: the
   *  correction. */
  bool
  accepts(std::uint32_t i,
          std::size_t j,
          const std::vector<double>& match,
          double allowed,
          double& error) const;
  /** Puts a kept scan's points, normals and tree into pLUM's vertex v. */
  void
  setScan(std::size_t v,
          const Cloud::ConstPtr& scan,
          std::vector<Eigen::Vector3f> normals,
          std::shared_ptr<const KdTreeIndex> tree);
  /** Collective: scan i's points from its owner to process `to`, which keeps them unless
   *  it held them already (a no-op without an exchange or if `to` owns them). */
  void
  share(std::size_t i, int to);
  /** On process `by`: one more link measured here needs scan i (if another's). */
  void
  borrow(std::size_t i, int by);
  /** Drops scan i's points if this process holds them for no link. */
  void
  release(std::size_t i);

  LoopClosureParameters params_;
  double median_range_;      ///< converts a rotation error to a displacement
  double source_voxel_size_; ///< the newer scan's sample when a loop pair is matched
  /** 2D scans (Parameters::planar): a loop match must also agree with the space each
   *  scan saw through (FreeSpace). */
  bool planar_;
  Eigen::Vector3d up_; ///< the vertical the free space is seen about (mutualConflicts)
  unsigned num_threads_;
  std::unique_ptr<Impl> impl_;
  std::shared_ptr<ScanExchange> exchange_;
  std::vector<Cloud::ConstPtr> scans_;  ///< own scans (null: another process's)
  std::vector<std::uint32_t> borrowed_; ///< links measured here that need scan i (not own)
  Poses poses_;
  std::vector<Link> links_;
  std::vector<std::uint32_t> loop_sources_; ///< source scan of each loop link
  std::vector<std::uint32_t> constrained_;  ///< scan of each sequence constraint
};

/** Candidates for loop links of scan j, nearest first: scans i <= j - min_separation
 *  whose position is closer than `distance` (paper Sec. VI-C: cldist, loopsize) and from
 *  which the scanner went away and came back: the path from i to j (translation plus
 *  rotation times `range`, see registration::motionDisplacement) is at least
 *  2 x distance. Neighbours along a slow or stopped path are thus never a "loop", and a
 *  scanner turning in place closes a loop once it has turned far enough. */
std::vector<std::uint32_t>
loopCandidates(
    const Poses& poses, std::size_t j, double distance, int min_separation, double range);

/** How far the poses can have drifted between scans i and j: the shortest path between
 *  them through the graph, a step between consecutive scans as long as the motion
 *  (registration::motionDisplacement at `range`), a loop link `link_length`. A loop
 *  closed since puts two scans nearer than the path the scanner took between them.
 *  Throws std::out_of_range for a scan beyond the poses. */
double
loopPath(const Poses& poses,
         const std::vector<Link>& links,
         std::size_t i,
         std::size_t j,
         double range,
         double link_length);

/** How well a map agrees with itself where the scanner came back: each scan j paired with
 *  its nearest loopCandidates scan i (as loop closing seeks them, at the poses given),
 *  the pair's mutualConflicts. Single walls give a few percent (people, doors, what one
 *  scan saw past the other's edge); a doubled wall puts one scan's wall into the other's
 *  free space. */
struct RevisitConsistency {
  std::size_t pairs = 0;       ///< revisits measured
  double mean_conflicts = 0.0; ///< mean share of conflicting points over the pairs
  std::size_t conflicting = 0; ///< pairs above kMaxLoopConflicts
};

/** RevisitConsistency of `poses` with the scans' reduced points (scanner frame; pairs with
 *  a null scan are left out) and resolved parameters' loop distance, min_separation,
 *  median range, overlap_distance (the margin), up axis and threads. The same for any
 *  thread count. */
RevisitConsistency
revisitConsistency(const std::vector<Cloud::ConstPtr>& scans,
                   const Poses& poses,
                   const Parameters& resolved);

/** Closes a loop before relaxation: the poses of scans i+1..j move by growing shares of
 *  the correction that puts j where `measured` (j's pose in i's frame) says, by path
 *  length along the loop (by index where the scanner did not move). */
void
distributeLoopError(Poses& poses, std::size_t i, std::size_t j, const Pose& measured);

} // namespace slam
} // namespace pcl_parallel
