/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <limits>

namespace pcl_parallel {
namespace slam {

/** How a scan is matched: against its predecessor (the paper's sequential pICP, Sec. II)
 *  or against the local map of the recent scans (3DTK's metascan, KISS-ICP). */
enum class MatchTarget { kPreviousScan, kLocalMap };

/*
 * Everything the mapping pipeline can be told: one flat struct per stage, grouped in
 * Parameters. 3DTK slam6D's option names are in brackets. Lengths are in the scans' units
 * (metres in the examples); a length of 0 is automatic: resolve() sets it from the first
 * scan's median range r (docs/design.md, "Automatic scale"), so one set of defaults serves
 * a tilting 2D scanner indoors (r ~ 4 m), a spinning LiDAR on a car (r ~ 15 m) and a
 * terrestrial scanner (r ~ 30 m).
 */

/** Reducer: which points a scan keeps, and how densely. */
struct ReductionParameters {
  double min_range = 0.0;                                     ///< [-M] drop closer points
  double max_range = std::numeric_limits<double>::infinity(); ///< [-m] drop farther ones
  double voxel_size = 0.0; ///< [-r] the reduction kept per scan; auto r / 20
  /** The registered sample: per voxel the measured point nearest its centroid
   *  (filters::voxelNearestToCentroid), so it lies on the surfaces; auto 3 voxels. */
  double source_voxel_size = 0.0;
};

/** Deskewer and motion model: undoing a spinning LiDAR's motion during its sweep. */
struct DeskewParameters {
  bool enabled = false; ///< [--deskew] by the predicted motion; off for stop-and-go scanners
  /** Seconds one sweep takes: with time stamps, a scan is deskewed by one sweep's share of
   *  the step (sweepMotion), so keyframes seconds apart are not deskewed by the whole step.
   *  0: each scan is the sweep after the previous one. */
  double sweep_period = 0.0;
  /** The head turns clockwise seen from +z (KITTI's Velodyne), from facing backwards;
   *  false: counter-clockwise (sweepTime). */
  bool sweep_clockwise = true;
};

/** Matcher: pICP against the local map or the previous scan (paper Sec. II, IV). */
struct MatcherParameters {
  MatchTarget target = MatchTarget::kLocalMap; ///< [--metascan] or scan to scan
  /** [-d] pICP's gate: its first value and, adaptive, its cap; auto 10 voxels. */
  double max_correspondence_distance = 0.0;
  /** A match is refined from its result within this gate (coarse to fine, docs/design.md):
   *  pairs across occlusion edges stay out of the final pose; auto 2 voxels. */
  double final_correspondence_distance = 0.0;
  int max_iterations = 50;              ///< [-i]
  double transformation_epsilon = 1e-8; ///< [--epsICP] stop: squared change of the transform
  bool point_to_plane = true;           ///< else point-to-point
  /** Normals estimated on the local map after each refresh (for sparse, non-repetitive
   *  patterns such as solid-state LiDARs', and 2D scans: resolve() sets it with
   *  Parameters::planar), not once per scan. */
  bool normals_from_map = false;
  /** KISS-ICP's adaptive gate (Vizzo et al. 2023, Sec. III-C): 3 sigma of how far matches
   *  moved the scans from the motion prior, Geman-McClure kernel of scale sigma / 3. */
  bool adaptive_threshold = true;
  /** With the adaptive gate, the motion prior enters pICP as a Gaussian prior
   *  (ParallelIterativeClosestPoint::setMotionPrior): directions a one-sided scan leaves
   *  unconstrained stay at the prediction (docs/design.md, "The motion prior's spread"). */
  bool motion_prior = true;
  /** The local map keeps voxels this near the scanner; auto max_range, else 5 r. */
  double map_distance = 0.0;
  double map_voxel_size = 0.0;   ///< local map voxel; auto 2 voxels
  int map_points_per_voxel = 20; ///< local map density
};

/** PoseGuess: where pICP starts when the motion model may be wrong. */
struct PoseGuessParameters {
  /** Local map without odometry: the map match starts from a match to the previous scan,
   *  which holds no copy of the scene left by earlier wrong poses (docs/design.md, "Real
   *  data"). */
  bool guess_from_previous_scan = true;
  /** Without odometry, the previous-scan match also starts from the prediction moved along
   *  the direction of travel (and turned) by multiples of the gate's sigma; the best fit
   *  wins (docs/design.md, "Speed hypotheses"). */
  bool speed_hypotheses = true;
  /** Without odometry, where the previous-scan match looks wrong, a search over all
   *  headings about `up` and translations (correlativeSearch) gives the guess
   *  (docs/design.md, "Pose search"): a stop-and-go scanner turned by any angle. */
  bool pose_search = true;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ(); ///< the vertical axis, scanner frame
};

/** LoopCloser: loops by pose distance, matched by pICP, relaxed by pLUM (Sec. III, V). */
struct LoopClosureParameters {
  bool enabled = true;           ///< [--no-loops] off: the front end's poses are final
  double distance = 0.0;         ///< [--cldist] scans closer than this may be linked; auto r
  int min_separation = 5;        ///< [--loopsize] ... if at least this many scans apart
  double min_overlap = 0.3;      ///< a loop link needs this share of points overlapping:
  double overlap_distance = 0.0; ///< within this of the other scan; auto 2 voxels
  int max_candidates = 16;       ///< nearest candidates looked at per scan; the best is matched
  double icp_distance = 0.0;     ///< loop pICP gate; auto the matcher's
  int icp_iterations = 0;        ///< loop pICP; auto the matcher's, at least 50
  double icp_epsilon = 0.0;      ///< loop pICP stop; auto the matcher's
  /** A loop's error must be explainable by the front end's drift: at most this fraction of
   *  the path between the scans through the graph (translation plus rotation times r; a
   *  loop closed since shortens it, slam::loopPath), or 2 overlap distances; a larger
   *  correction is a false match and is rejected. 2D scans search a window this wide
   *  (at most the loop distance) where pICP from the poses falls short. */
  double max_drift = 0.05;
  /** [-L] ELCH: a loop's error larger than overlap_distance is spread along it before
   *  pLUM. */
  bool distribute_error = true;
  bool relax_each_loop = true; ///< pLUM when a loop is found (the paper), not only at the end
  /** pLUM iterations when a loop closes during the run (finish() converges): bounds what a
   *  scanner that keeps revisiting costs. <= 0: lum_iterations. */
  int lum_iterations_per_loop = 5;
  // pLUM: pairs within a gate shrinking from lum_distance to lum_final_distance (x0.7 per
  // iteration), up to lum_iterations, until the mean pose update is below lum_epsilon.
  double lum_distance = 0.0;       ///< [-D] auto 10 voxels
  double lum_final_distance = 0.0; ///< auto 2 voxels
  int lum_iterations = 20;         ///< [-I]
  double lum_epsilon = 0.0;        ///< [--epsSLAM] auto voxel / 100
  /** Pairing steps per link and iteration (ParallelLUM::setLinkIterations). */
  int lum_link_iterations = 1;
  /** Pairs weighted by their normals (ParallelLUM::setPointToPlane). */
  bool lum_point_to_plane = true;
  std::size_t lum_queries_per_scan = 500; ///< pairs searched per scan and link direction
  /** The front end's matches as pose constraints between consecutive scans, each weighing
   *  as much as one pLUM link per scan its map held (docs/design.md, "Sequence
   *  constraints"); point-to-plane only. */
  bool sequence_constraints = true;
  /** > 0: a Cauchy kernel of this chi2 scale on each sequence constraint (e.g.
   *  kChi2Quantile99SixDof), so that a match the scans contradict yields. */
  double sequence_cauchy_scale = 0.0;
  /** After the last relaxation: where the scanner came back and the scans conflict at the
   *  relaxed poses without a link between them, the pair is matched again from those
   *  poses, linked where accepted, and the graph relaxed again (LoopCloser::linkRevisits),
   *  up to this many rounds: the loops a long drift hid during the run. < 0: auto, 3 for
   *  2D scans (a slice's match has a narrow basin), else 0. */
  int revisit_rounds = -1;
};

/** The pipeline's parameters, a struct per stage. */
struct Parameters {
  /** Reduction. */
  ReductionParameters reduction;
  /** Deskewing. */
  DeskewParameters deskew;
  /** The front end's pICP. */
  MatcherParameters matcher;
  /** Where pICP starts without odometry. */
  PoseGuessParameters guess;
  /** Loop detection and closing. */
  LoopClosureParameters loops;
  /** The scans' median range r, which sets the automatic lengths and converts rotations
   *  to displacements; auto: the first scan's. */
  double median_range = 0.0;
  /** The paper's 2D special case (Sec. VII): the scans are a 2D scanner's, in its plane
   *  normal to guess.up, and it moves in that plane. pICP and pLUM solve for the
   *  translation in the plane and the heading alone, normals lie in the plane (the walls'
   *  lines) and the front end's come from the local map (a single line scan's are too
   *  sparse and noisy), the motion prior holds the translation only, loop matches must
   *  agree with the space both scans saw through, and resolve() sets a finer registered
   *  sample and a wider loop distance (docs/design.md, "2D logs"). mapDirectory sets it for a
   *  directory's 2D scans (io::ScanDirectory::planar). */
  bool planar = false;
  unsigned num_threads = 0; ///< 0: all cores
};

/** `p` with every automatic length set from median range `r` (p.median_range where it is
 *  set). Throws std::invalid_argument for r <= 0, a negative or non-finite sweep period,
 *  or `planar` with an up axis other than z. */
Parameters
resolve(const Parameters& p, double median_range);

/** Whether every automatic length of `p` is set (resolve's result). */
bool
isResolved(const Parameters& p);

} // namespace slam
} // namespace pcl_parallel
