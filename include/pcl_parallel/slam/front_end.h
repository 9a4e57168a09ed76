/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/local_map.h>
#include <pcl_parallel/slam/types.h>

#include <Eigen/Geometry>

#include <limits>
#include <memory>
#include <optional>
#include <utility>

namespace pcl_parallel {
namespace search {
template <typename PointT>
class KdTree;
} // namespace search

namespace slam {

/** How a scan is matched: against its predecessor (the paper's sequential pICP, Sec. II)
 *  or against the local map of the recent scans (3DTK's metascan, KISS-ICP). */
enum class MatchTarget { kPreviousScan, kLocalMap };

/** The front end's settings; lengths in the scans' units (metres for the defaults). */
struct FrontEndParameters {
  MatchTarget target = MatchTarget::kLocalMap;
  double voxel_size = 0.1; ///< scan reduction kept in the map and for loop closing
  /** Coarser sample of the registered points: per voxel the measured point nearest its
   *  centroid (filters::voxelNearestToCentroid), so they lie on the surfaces. */
  double source_voxel_size = 0.3;
  double map_distance = 30.0;               ///< local map: voxels within this of the scanner
  double map_voxel_size = 0.3;              ///< local map voxel
  int map_points_per_voxel = 20;            ///< local map density
  double max_correspondence_distance = 0.5; ///< pICP gate (adaptive: its first value and cap)
  /** A match whose gate is wider than this is refined from its result within this gate
   *  (coarse to fine): the wide gate is the prediction's basin, the narrow one keeps
   *  pairs across occlusion edges and unseen surfaces out of the final pose. With
   *  point-to-plane, never below 9x the wide match's residual RMS, so the kernel
   *  (gate / 9) keeps the inliers (docs/design.md, "Coarse to fine"). 0: no refinement. */
  double final_correspondence_distance = 0.2; ///< 2 voxels, as the pipeline's default
  /** KISS-ICP's adaptive gate (Vizzo et al. 2023, Sec. III-C): 3 sigma of how far the
   *  matches moved the scans from the motion prior, Geman-McClure kernel of scale
   *  sigma / 3. Off: the fixed gate and no kernel. */
  bool adaptive_threshold = true;
  /** With the adaptive threshold: the motion prior (odometry step or constant velocity)
   *  enters pICP as a Gaussian prior (ParallelIterativeClosestPoint::setMotionPrior), so
   *  directions a sparse or one-sided scan leaves unconstrained stay at the prediction
   *  (docs/design.md, "Real data"). Its spread: the RMS of how far the matches moved the
   *  scans from the prediction, in translation and in rotation each, once 20 such
   *  deviations are in; before, the threshold's sigma ("The motion prior's spread"). */
  bool motion_prior = true;
  /** Local map without odometry: the map match starts from a match to the previous scan
   *  (from constant velocity), not from constant velocity itself. Where the motion
   *  changes more between scans than the map's basin allows (keyframes metres apart, a
   *  car pulling away, a handheld scanner swung), a map match from a poor guess can slide
   *  into the copy of the scene that earlier wrong poses left in the map, and that error
   *  reinforces itself; a single previous scan holds no such copy (docs/design.md,
   *  "Real data"). Ignored with odometry, whose step is the guess. */
  bool guess_from_previous_scan = true;
  /** Without odometry, the match to the previous scan (the map match's guess, or with
   *  kPreviousScan the match itself) also starts from the prediction moved
   *  along the direction of travel by -2, -1, +1 and +2 sigma of the adaptive gate (none
   *  behind the previous scan's position: speed, not direction), and
   *  the start whose match fits the previous scan best (pICP's fitness, pairs within
   *  sqrt(gate): metres assumed, docs/design.md "Speed hypotheses")
   *  gives the guess. Constant velocity misses a change of speed (a car pulling away
   *  between keyframes 0.5 s apart, 5-8 m), and along a street a start metres short
   *  converges to a false fit near the previous pose, which then sets the velocity
   *  (docs/design.md, "Speed hypotheses"). Starts within the refinement gate of the
   *  prediction are not tried, so a narrow gate costs nothing. A match that ends where
   *  the previous scan was taken shares its sampling pattern and does not replace one
   *  that moves (docs/design.md, "Standing still"). */
  bool speed_hypotheses = true;
  /** Without odometry, where the match to the previous scan looks wrong (the first one,
   *  one where a turn hypothesis won, or one that overlaps the previous scan less than
   *  0.7 times the recent matches' median), the pose is also searched over all headings
   *  about `up` and translations (correlativeSearch), and pICP from its best candidates
   *  gives the guess where one overlaps the previous scan more (docs/design.md, "Pose
   *  search"). For motion nothing predicts: a stop-and-go scanner without initial poses
   *  is carried from one station to the next and turned by any angle. */
  bool pose_search = true;
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ(); ///< the vertical axis, scanner frame
  /** Point-to-plane pICP instead of point-to-point. */
  bool point_to_plane = true;
  /** Point-to-plane normals: false (default) estimates them once per scan from its
   *  reduced points and carries them in the map (fast; right for scanners that
   *  sample surfaces densely in one scan: spinning, tilting, terrestrial); true estimates
   *  them on the local map after each refresh (slower on large maps; better for sparse,
   *  non-repetitive patterns such as Livox's, measured on fastlio_quick_shack). */
  bool normals_from_map = false;
  int max_iterations = 50;
  double transformation_epsilon = 1e-8; ///< pICP stop: squared change of the transform
  /** Deskew scans of a spinning LiDAR (sweep time from azimuth, see sweepTime) with the
   *  predicted motion; off for stop-and-go scanners. */
  bool deskew = false;
  /** Seconds one sweep takes (0.1 for a 10 Hz LiDAR). With deskew and the scans' time
   *  stamps, a scan is deskewed by one sweep's share of the predicted step (sweepMotion),
   *  so keyframes taken seconds apart are not deskewed by the whole step between them.
   *  0: each scan is the sweep after the previous one, deskewed by the whole step. */
  double sweep_period = 0.0;
  /** The head turns clockwise seen from +z in the scans' frame (KITTI's Velodyne), from
   *  facing backwards; false: counter-clockwise (see sweepTime). */
  bool sweep_clockwise = true;
  unsigned num_threads = 0;
};

/** A scan as the front end reduced it: deskewed and reduced, with its tree and normals. */
struct ReducedScan {
  Cloud::Ptr reduced; ///< deskewed, reduced at voxel_size, scanner frame
  /** The reduced points' normals (scanner frame, from their 10 nearest reduced points),
   *  zero where a neighbourhood is no plane: pLUM takes them (LoopCloser::addScan). */
  std::vector<Eigen::Vector3f> normals;
  /** The reduced points' k-d tree (scanner frame): built once, for the normals, the next
   *  scan's match to this one and pLUM (LoopCloser::addScan). */
  std::shared_ptr<const KdTreeIndex> tree;
};

/** What the front end did with one scan. */
struct FrontEndResult {
  Pose pose;        ///< matched pose (world)
  Pose prediction;  ///< where the motion prior put it
  ReducedScan scan; ///< the scan deskewed and reduced, with its tree and normals
  std::size_t source_points = 0;
  bool converged = true; ///< false: pICP failed and the prediction was kept
  double fitness = 0.0;  ///< pICP's mean squared pair distance, within the gate
  double gate = 0.0;     ///< the correspondence distance used
  /** Where the winning start of the speed hypotheses lay along the direction of travel,
   *  from the prediction (scan units; 0: the prediction's, or none tried). */
  double start_offset = 0.0;
  /** The winning turn-rate hypothesis: the predicted turn scaled by 1 + start_turn (-1:
   *  stopped, 1: doubled; 0: the prediction's, or none tried). */
  double start_turn = 0.0;
  bool pose_searched = false; ///< the pose search ran (FrontEndParameters::pose_search)
  /** With deskewing: the scan was deskewed again by its matched step, which differed
   *  from the predicted one (a turn begun or ended), and matched again. */
  bool deskewed_again = false;
  /** The pose search's winning start, turned about `up` from the previous scan's
   *  heading (rad); NaN: no search ran, or the prediction's match won. */
  double start_heading = std::numeric_limits<double>::quiet_NaN();
  /** The match's information (point-to-plane: pICP's final Hessian over its residual
   *  variance, without the motion prior): how well the scan's pose relative to the map,
   *  or to the previous scan, is known. Zero when pICP did not run or failed. */
  Information information = Information::Zero();
  double information_pairs = 0.0; ///< ... from this many pairs (sum of robust weights)
  /** How many scans the match was made against, in effect: (sum n_s)^2 / sum n_s^2 over
   *  the scans s that hold the nearest map points of the matched source points (1: the
   *  previous scan, or one scan held them all; K: K scans in equal shares). 1 for a match
   *  to the previous scan. docs/design.md, "Sequence constraints". */
  double map_scans = 1.0;
  /** With deskewing, on the second scan: the first scan deskewed again, now that the
   *  first step is known (it came before any motion was), to replace the one kept. */
  std::optional<ReducedScan> first_scan;
};

/**
 * \brief The front end (paper Sec. II with KISS-ICP's structure): per scan, predict the
 * pose from the odometry step or, without odometry, constant velocity (in time when the
 * scans have time stamps); deskew; reduce; match with pICP; update the local map.
 */
class FrontEnd {
public:
  explicit FrontEnd(const FrontEndParameters& params = FrontEndParameters());
  ~FrontEnd();

  /** Matches the next scan (scanner frame). `odometry`: its odometry pose, if known;
   *  `stamp`: its time (s). With time stamps, constant velocity is per second, not per
   *  scan (keyframes come at uneven intervals), and deskewing by sweep_period takes one
   *  sweep's share of the step (without them, the whole predicted step). `sweep_times`:
   *  each point's time in its sweep (sweepFractions), deskewing by those instead of the
   *  azimuth; empty: by azimuth (sweep_clockwise). Throws std::invalid_argument for
   *  sweep_times of another size than the scan's. */
  FrontEndResult
  track(const Cloud& scan,
        const std::optional<Pose>& odometry = std::nullopt,
        std::optional<double> stamp = std::nullopt,
        const std::vector<float>& sweep_times = {});

  /** Moves the front end's state (last pose, map) by a rigid correction, e.g. after
   *  loop closing moved the latest scan from last pose to correction * last pose. */
  void
  applyCorrection(const Pose& correction);

  /** Sets the pose of the last scan (loop closing); the map moves with it. */
  void
  setLastPose(const Pose& pose);

  const Pose&
  lastPose() const
  {
    return pose_;
  }

private:
  struct Registration;
  /** The predicted step since the previous scan, and the motion during this scan's sweep
   *  (what deskewing undoes). */
  struct Motion {
    Pose step = Pose::Identity();
    Pose sweep = Pose::Identity();
  };
  Motion
  predictMotion(const std::optional<Pose>& odometry, double gap);
  double
  gate() const;
  /** The motion prior's standard deviations, translation and rotation (rad). */
  std::pair<double, double>
  priorSpread() const;
  /** priorSpread() where pICP takes a motion prior (adaptive threshold and motion_prior). */
  std::optional<std::pair<double, double>>
  priorSpreadIfUsed() const;
  /** The motion prior's mean for the final match from `guess`: the prediction, or the
   *  guess where the pose search placed the scan (r.start_heading). */
  static const Pose&
  priorMean(const FrontEndResult& r, const Pose& guess);
  /** Starts tried beside the prediction without odometry (speed_hypotheses). */
  struct Hypotheses {
    /** Speed: along `travel` (scanner frame) at -2..2 sigma of the gate; none at 0 (no
     *  direction, or a gate whose starts all lie inside the refinement gate). */
    Eigen::Vector3d travel = Eigen::Vector3d::Zero();
    double sigma = 0.0;
    double speed = 0.0; ///< the predicted step's length along `travel`
    /** Turn rate: the predicted turn stopped and doubled; none at angle 0 (a turn that
     *  moves the median range's points less than the refinement gate). */
    Eigen::AngleAxisd turn = Eigen::AngleAxisd(0.0, Eigen::Vector3d::UnitZ());
    double range = 0.0; ///< the scan's median range: poses compared by motionDisplacement
    bool
    any() const
    {
      return sigma > 0.0 || turn.angle() > 0.0;
    }
  };
  /** Right after `own`, the best guess so far (the hypotheses' winner, else the
   *  prediction's match to the previous scan): where `own` looks wrong (pose_search),
   *  the best of correlativeSearch's candidates matched, if it overlaps the previous scan
   *  1.25 times more than `own`, agrees with it more (overlap less free-space conflicts,
   *  FreeSpace; both on upright points where the scans have them) and ends elsewhere;
   *  r.start_heading says which. `range`: the source's median range where known
   *  (Hypotheses::range), else 0. */
  std::optional<Pose>
  searchPose(const Cloud::ConstPtr& source,
             ReducedScan& scan,
             const std::optional<Pose>& own,
             double range,
             FrontEndResult& r);
  /** Keeps the overlap of the latest match to the previous scan (the last 20). */
  void
  keepOverlap(double overlap);
  /** Without odometry, right after `own`, the prediction's match to the previous scan:
   *  the best of the hypotheses' matches (bestHypothesis) where one beats it, the pose
   *  search's (searchPose) where even that looks wrong; none if neither won. */
  std::optional<Pose>
  betterGuess(const Cloud::ConstPtr& source,
              ReducedScan& scan,
              const Pose& prediction,
              const std::optional<Pose>& own,
              FrontEndResult& r);
  /** Where the match starts: the prediction, or its match to the previous scan
   *  (guess_from_previous_scan), or betterGuess's (which start won goes to
   *  r.start_offset, r.start_turn and r.start_heading). */
  Pose
  initialGuess(const Cloud::ConstPtr& source,
               ReducedScan& scan,
               const Pose& prediction,
               bool odometry,
               FrontEndResult& r);
  /** The hypotheses for this scan and prediction (none: off, or no previous scan). */
  Hypotheses
  hypotheses(const Cloud& source, const Pose& prediction) const;
  /** How close two starts or matches lie in one basin: the refinement gate, at least a
   *  voxel. */
  double
  sameSolution() const;
  /** Whether a match (in the previous scan's frame) puts the scanner where the previous
   *  scan was taken, within sameSolution(), at any heading: there the two scans share
   *  their sampling pattern, and their fitness and overlap are biased towards it
   *  (docs/design.md, "Standing still"). */
  bool
  atPreviousScan(const Pose& local) const;
  /** Whether `other` may replace `leader` (both in the previous scan's frame; poses
   *  compared at `range`): not if it is the same solution, nor if it stands at the
   *  previous scan where the leader moves (atPreviousScan). */
  bool
  isRival(const Pose& leader, const Pose& other, double range) const;
  /** Right after `own`, the prediction's match to the previous scan: the best of the
   *  hypotheses' matches if one fits better and ends elsewhere (more than sameSolution()
   *  at the median range; r.start_offset and r.start_turn say which), else none. */
  std::optional<Pose>
  bestHypothesis(const Cloud::ConstPtr& source,
                 const Pose& prediction,
                 const std::optional<Pose>& own,
                 const Hypotheses& h,
                 FrontEndResult& r);
  bool
  hasPrevious() const;
  /** The scan deskewed by the sweep's motion (params_.deskew; at its points' sweep times
   *  when given, else by azimuth) and reduced; its tree and normals not yet built
   *  (describe). */
  ReducedScan
  reduce(const Cloud& scan, const std::vector<float>& sweep_times, const Pose& sweep) const;
  /** The points pICP registers: per source voxel the reduced point nearest its centroid. */
  Cloud::Ptr
  sourceOf(const ReducedScan& scan) const;
  /** The first scan deskewed by `sweep` and reduced, the map and previous scan made of it
   *  again (pose_ still the first scan's). */
  ReducedScan
  deskewFirstAgain(const Pose& sweep);
  /** Puts the reduced scan into the map at pose_ as scan `id` (1 for the first) with its
   *  tree and normals (built here unless the pose search built them), and keeps it as
   *  the previous scan where that is matched. */
  ReducedScan
  keep(ReducedScan scan, std::uint32_t id);
  /** pICP of the source from the prediction against the previous scan, \a refined
   *  within the final gate, its motion prior at \a prior_mean (null: the prediction);
   *  the world pose, or none if it did not converge. */
  std::optional<Pose>
  alignToPrevious(const Cloud::ConstPtr& source,
                  const Pose& prediction,
                  bool refined,
                  const Pose* prior_mean = nullptr);
  /** The source matched from \a start to the match target (the local map, whose tree
   *  the map match's pICP holds, or the previous scan), coarse to fine from the gate,
   *  its motion prior at \a prior_mean: the world pose, or none. */
  std::optional<Pose>
  matchFrom(const Cloud::ConstPtr& source, const Pose& start, const Pose& prior_mean);
  /** The sweep's motion from the matched step (one sweep's share, at the velocity of the
   *  step's end, as predictMotion's) where deskewing by it instead of \a predicted moves
   *  the reduced scan's farthest point more than kRedeskewVoxels; none elsewhere
   *  (docs/design.md, "Deskewing by the match"). */
  std::optional<Pose>
  sweepToDeskewAgain(const Pose& matched,
                     const Pose& predicted,
                     double gap,
                     const Cloud& reduced) const;

  FrontEndParameters params_;
  std::unique_ptr<Registration> icp_;
  LocalMap map_;
  /** The last scan, reduced, in its own frame (its pose is pose_), with its tree: the
   *  one built for its normals. */
  MapCloud::Ptr previous_;
  pcl::shared_ptr<search::KdTree<MapPoint>> previous_tree_;
  std::shared_ptr<const KdTreeIndex> previous_index_; ///< previous_tree_'s index
  Cloud::ConstPtr previous_points_;                   ///< its points, without normals
  std::vector<double> overlaps_; ///< of the recent matches to the previous scan
  /** The direction of the last step longer than a voxel, in the scanner's frame: where
   *  speed hypotheses go when the predicted step is too short to have one. */
  Eigen::Vector3d heading_ = Eigen::Vector3d::Zero();
  MapCloud::ConstPtr target_; ///< what pICP's target tree was built from
  std::size_t scans_ = 0;
  Pose pose_ = Pose::Identity();
  Pose velocity_ = Pose::Identity(); ///< last matched step
  double velocity_span_ = 0.0;       ///< ... taken over this many seconds (0: unknown)
  std::optional<Pose> last_odometry_;
  std::optional<Pose> odometry_step_; ///< the last odometry step
  double odometry_span_ = 0.0;        ///< ... taken over this many seconds (0: unknown)
  std::optional<double> last_stamp_;
  Cloud::Ptr first_scan_; ///< the first scan as given, until the first step is known
  std::vector<float> first_scan_times_; ///< its points' sweep times, if given
};

} // namespace slam
} // namespace pcl_parallel
