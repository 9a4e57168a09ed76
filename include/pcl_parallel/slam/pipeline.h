/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/loop_closure.h>
#include <pcl_parallel/slam/motion_model.h>
#include <pcl_parallel/slam/parameters.h>
#include <pcl_parallel/slam/scan_record.h>
#include <pcl_parallel/slam/types.h>

#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <vector>

namespace pcl_parallel {
namespace slam {

class Matcher;

/** How far pICP moved the scans from their odometry's steps, over how long the steps are:
 *  the median ScanReport::correction over the median ScanReport::predicted_step, over the
 *  first kOdometryDisagreementSteps steps (later, a wrong odometry has bent the map the
 *  scans are matched to, and the matches follow it). Odometry in the scans' frame leaves
 *  hundredths to tenths; odometry in another frame (KITTI's poses.txt: the left camera's)
 *  about 1 (docs/design.md, "Odometry in another frame"). None for fewer than 5 steps, or
 *  where the median step is under `min_step` (a scanner standing still). The first scan
 *  (no step) is left out. */
std::optional<double>
odometryDisagreement(const std::vector<ScanReport>& reports, double min_step);

/** Scan k (scanner frame, full resolution; point_times as read, or empty) as a map at
 *  `poses` shows it: with p.deskew.enabled deskewed as the front end deskews it
 *  (deskewSweep by sweepTimes), by the motion at its pose there (sweepMotionAt with
 *  `stamps`, one per pose or none, and p.deskew); else as given. A second streaming pass
 *  over the scans with the final poses builds the full-resolution map from these. */
Cloud::Ptr
mapFrame(const Cloud& scan,
         const std::vector<double>& point_times,
         const Poses& poses,
         const std::vector<double>& stamps,
         std::size_t k,
         const Parameters& p);

/** Scan k at full resolution as the map shows it (mapFrame's frame), prepared on
 *  `num_threads` threads; null: a scan this process does not map. */
using MapScanSource = std::function<Cloud::ConstPtr(std::size_t k, unsigned num_threads)>;

/** The merged map of scans [begin, end): each one read by `read`, moved by its pose, one
 *  centroid per voxel of voxel_size (filters::VoxelCentroidMap: memory per voxel, not per
 *  point); voxel_size <= 0 keeps every point. Scans are read and grouped a batch at a
 *  time, one per thread (the reading is serial work), and added in order, so the result
 *  is the scan-by-scan pass's for any thread count. `step` is called after each scan
 *  (done, total). */
Cloud::Ptr
assembleMap(const MapScanSource& read,
            const Poses& poses,
            std::size_t begin,
            std::size_t end,
            double voxel_size,
            unsigned num_threads,
            const std::function<void(int, int)>& step = {});

/** An odometryDisagreement above this says the odometry is in another frame, or broken:
 *  odometry in the scans' frame gives a few hundredths, in another frame about 1
 *  (docs/design.md, "Odometry in another frame"). */
constexpr double kOdometryDisagreementLimit = 0.25;

/** odometryDisagreement looks at this many steps from the first. */
constexpr std::size_t kOdometryDisagreementSteps = 20;

/** Seconds spent per stage. */
struct StageTimes {
  /** Seconds spent in each stage. */
  ///@{
  double preprocess = 0.0, front_end = 0.0, loop_detection = 0.0, loop_closing = 0.0;
  ///@}
  /** Sum of the stages' seconds. */
  double
  total() const
  {
    return preprocess + front_end + loop_detection + loop_closing;
  }
  /** Adds another run's times. */
  void
  add(const StageTimes& t)
  {
    preprocess += t.preprocess;
    front_end += t.front_end;
    loop_detection += t.loop_detection;
    loop_closing += t.loop_closing;
  }
};

/**
 * \brief The mapping pipeline (paper Sec. VI; KISS-ICP's per-scan structure) as a
 * streaming library stage: feed scans one at a time, get poses, links and the map.
 *
 * Per scan: crop -> front end (predict, deskew, reduce, pICP against the local map or the
 * previous scan) -> add to the pose graph -> loop detection -> pLUM when a loop closes.
 * finish() relaxes once more. Only each scan's reduced points are kept (bytesPerScan()),
 * never the full-resolution scans. The result is the same for any thread count.
 */
class Pipeline {
public:
  /** The automatic lengths come from the first scan's median range. */
  explicit Pipeline(const Parameters& params = Parameters());
  /** Lengths from a given median range (e.g. a segment's pipeline takes the sequence's);
   *  `first_index`: the index of the first scan, in error messages. */
  Pipeline(const Parameters& params, double median_range, std::size_t first_index = 0);
  ~Pipeline();

  /** Adds the next scan (scanner frame) with its odometry pose and its time stamp (s),
   *  if known: either every scan has one or none. `point_times`: each point's time as the
   *  driver gives it (any unit and origin, e.g. a PCD's "t" field; io::loadScan reads
   *  them), which deskewing then uses instead of the azimuth (sweepFractions); empty or
   *  all equal (spansSweep): by azimuth.
   *  Returns the scan's index. Throws std::invalid_argument for a scan with no points
   *  left after cropping, a non-finite odometry pose, stamp or point time, point times of
   *  another count than the points, or, when deskewing by a sweep period, a missing stamp
   *  or one not after the previous scan's. */
  std::size_t
  addScan(const Cloud& scan,
          const std::optional<Pose>& odometry = std::nullopt,
          std::optional<double> stamp = std::nullopt,
          const std::vector<double>& point_times = {});

  /** addScan's first half, the front end's stages: crops the scan, predicts its motion,
   *  deskews, reduces, guesses and matches it (the pose graph is not touched). Returns
   *  the scans this one made final, in order: itself, except that with deskewing the
   *  first scan waits for the second (its deskewing needs the first step) and comes
   *  with it, and without odometry the first four come together, once the first two are
   *  placed again along their paths (placeFirstAgain). A pipeline used for this alone
   *  matches a segment of a sequence (segments.h). Throws as addScan. */
  std::vector<ScanRecord>
  track(const Cloud& scan,
        const std::optional<Pose>& odometry = std::nullopt,
        std::optional<double> stamp = std::nullopt,
        const std::vector<double>& point_times = {});

  /** The scan track() still holds (the first, with deskewing, when no second came). */
  std::vector<ScanRecord>
  drain();

  /** addScan's second half for a scan this pipeline's track() matched: adds it to the
   *  pose graph at its front-end pose, detects loops, relaxes, and moves the front end to
   *  a corrected pose (so addScan(s) is addTracked for each of track(s)). */
  std::size_t
  addTracked(ScanRecord scan);

  /** addScan's second half for a scan another pipeline's front end matched: adds it to
   *  the pose graph at the previous scan's current pose times `scan.step` (the first
   *  scan at its front-end pose), detects loops, relaxes. Returns the scan's index. With
   *  an exchange, a scan another process owns comes without points (scan.scan.reduced
   *  null, report.reduced_points its size), and the call is collective. */
  std::size_t
  addMatched(ScanRecord scan);

  /** Spreads the loop closer's scans over processes (LoopCloser::setExchange; e.g.
   *  mpi::RankExchange); requires the median-range constructor. */
  void
  setExchange(std::shared_ptr<ScanExchange> exchange);

  /** Adds the scan track() still holds (drain), then a final pLUM over the whole graph
   *  (when loops were found). */
  void
  finish();

  /** Number of scans added. */
  std::size_t
  size() const
  {
    return front_end_poses_.size();
  }
  /** Current best poses: after the last loop closing. */
  const Poses&
  poses() const;
  /** The front end's trajectory: the steps it matched, chained from the first pose without
   *  the loop closures' corrections (it continues from the corrected poses, but these are
   *  what it measured: its drift, comparable with a run without loop closing). */
  const Poses&
  frontEndPoses() const
  {
    return front_end_poses_;
  }
  /** The pose graph's links. */
  const std::vector<Link>&
  links() const;
  /** One report per scan. */
  const std::vector<ScanReport>&
  reports() const
  {
    return reports_;
  }
  /** Time per stage so far. */
  const StageTimes&
  times() const
  {
    return times_;
  }
  /** Adds time spent on this pipeline's scans elsewhere (the segments' front ends). */
  void
  addTimes(const StageTimes& t)
  {
    times_.add(t);
  }
  /** The parameters as given (automatic lengths 0). */
  const Parameters&
  parameters() const
  {
    return params_;
  }
  /** The parameters with the automatic lengths resolved (resolve); after the first scan,
   *  or from the median-range constructor on. */
  const Parameters&
  resolvedParameters() const
  {
    return resolved_;
  }
  /** Loop links finish() added where revisits conflicted after the run
   *  (LoopClosureParameters::revisit_rounds). */
  std::size_t
  revisitLinks() const
  {
    return revisit_links_;
  }
  /** Number of pLUM relaxations run. */
  int
  relaxations() const
  {
    return relaxations_;
  }
  /** A scan's reduced points (scanner frame), as kept for loop closing and the map; null
   *  where another process owns the scan (setExchange). */
  Cloud::ConstPtr
  reducedScan(std::size_t i) const;
  /** How well the map agrees with itself where the scanner came back (revisitConsistency
   *  of the kept scans), at the current poses or the front end's; pairs with a scan
   *  another process owns are left out. */
  RevisitConsistency
  consistency(bool front_end = false) const;
  /** The map: the kept scans at the current poses, reduced with voxel_size (<= 0: none);
   *  with an exchange, of this process's own scans. Full resolution: a second pass over
   *  the scans through mapFrame, as pcl_pslam builds map.pcd. */
  Cloud::Ptr
  map(double voxel_size) const;
  /** Bytes this process keeps per scan of the sequence (reduced points, their k-d trees
   *  and normals, poses). */
  std::size_t
  bytesPerScan() const;
  /** Scans whose points this process keeps (all without an exchange). */
  std::size_t
  keptScans() const
  {
    return loops_ ? loops_->keptScans() : 0;
  }

private:
  struct Stages;
  /** Resolves the lengths from the median range and creates the stages. */
  void
  start(double median_range);
  /** Throws std::invalid_argument for scan `index`'s stamp as addScan documents. */
  void
  checkStamp(std::size_t index, const std::optional<double>& stamp) const;
  /** The scan checked and cropped, its points' sweep times cropped with it; starts the
   *  stages on the first scan. Throws as addScan. */
  Cloud::Ptr
  admit(const Cloud& scan,
        const std::optional<Pose>& odometry,
        std::optional<double> stamp,
        const std::vector<double>& point_times,
        std::vector<float>& sweep_times);
  /** The scan deskewed by `sweep` and reduced. */
  ReducedScan
  reduce(const Cloud& scan, const std::vector<float>& sweep_times, const Pose& sweep) const;
  /** Guess and match (PoseGuess, Matcher); with deskewing, deskewAgain. */
  void
  match(ScanRecord& r,
        Cloud::Ptr& source,
        const Cloud& scan,
        const std::vector<float>& sweep_times,
        const MotionPrediction& m,
        bool odometry);
  /** PoseGuess's start for r (without odometry each start matched on the registered
   *  sample deskewed by its own motion, deskewing by azimuth); `source` becomes the
   *  start's own sample where that moves the scan beyond the final gate, and
   *  `sample_of_scan` false. */
  Pose
  guessStart(ScanRecord& r,
             Cloud::Ptr& source,
             const std::vector<float>& sweep_times,
             const MotionPrediction& m,
             bool odometry,
             bool& sample_of_scan);
  /** A scan deskewed by the predicted step and matched (`matched`), deskewed again where
   *  the matched step's sweep moves it by more than half a voxel: by that sweep and
   *  matched again, then along the path its points show (followPath). The pose of the
   *  last match of r.scan (none: it did not converge). */
  std::optional<Pose>
  deskewAgain(ScanRecord& r,
              Cloud::Ptr& source,
              const Cloud& scan,
              const std::vector<float>& sweep_times,
              const MotionPrediction& m,
              Pose matched,
              const Pose& prior_mean,
              bool sample_of_scan);
  /** A scan deskewed along its sweep's path: the reduced scan, its registered sample and
   *  its refined pose. */
  struct AlongPath {
    ReducedScan scan;
    Cloud::Ptr source;
    Pose pose;
  };
  /** The sweep's path fitted to `matcher`'s map from `matched` at the constant velocity
   *  of `sweep` (SweepPath, kSweepPieces pieces, its prior in the sweep's time: the sweep
   *  period, else `gap`, the seconds since the previous scan, else 0.1 s), `scan`
   *  deskewed along it and refined (docs/design.md, "A sweep's path"); none where the fit
   *  or the refinement fails. */
  std::optional<AlongPath>
  alongPath(Matcher& matcher,
            const Cloud& scan,
            const std::vector<float>& sweep_times,
            const Pose& sweep,
            const Pose& matched,
            const Pose& prior_mean,
            const Pose& at,
            double gap) const;
  /** alongPath on the front end's map, into r.scan and `source`. The refined pose; none
   *  where the fit or the refinement fails (the matcher then holds no match of r.scan). */
  std::optional<Pose>
  followPath(ScanRecord& r,
             Cloud::Ptr& source,
             const Cloud& scan,
             const std::vector<float>& sweep_times,
             const Pose& sweep,
             const Pose& matched,
             const Pose& prior_mean,
             double gap);
  /** The held first scan deskewed by `sweep`: kept again as the map and previous scan. */
  void
  keepFirstAgain(const Pose& sweep);
  /** Without odometry: the second scan, then the first, matched again to the map of the
   *  other settling scans and deskewed along its path; the first keeps its pose, the
   *  others and the front end move with it (docs/design.md, "The first sweeps"). */
  void
  placeFirstAgain();
  /** Settling scan j placed again as placeFirstAgain says. */
  void
  placeAgain(std::size_t j);
  /** The match's figures in r.report: step, reduced points, correction, predicted step. */
  void
  reportMatch(ScanRecord& r, const Pose& before) const;
  /** The records track() returns for `r`: see track(). */
  std::vector<ScanRecord>
  release(ScanRecord r);
  /** finish()'s pLUM over the whole graph, its iterations reported with the last scan. */
  void
  relaxAtEnd();
  /** Moves the front end (last pose and map) to `pose` for its last scan (loop closing). */
  void
  correctFrontEnd(const Pose& pose);
  /** The graph half of addScan/addMatched for a scan at `pose`. */
  std::size_t
  addToGraph(ScanRecord scan, const Pose& pose);

  Parameters params_;
  Parameters resolved_;
  std::unique_ptr<Stages> stages_;
  std::unique_ptr<LoopCloser> loops_;
  std::optional<ScanRecord> held_; ///< the first scan, until the first step is known
  /** A first scan as given, with what deskewing it takes. */
  struct FirstSweep {
    Cloud::Ptr points;
    std::vector<float> times;      ///< its points' sweep times, if given
    Pose sweep = Pose::Identity(); ///< the first step's sweep, which deskewed it
    double gap = 0.0;              ///< the seconds of the first step (0: no stamps)
  };
  /** Without odometry and with deskewing: the first two scans as given, and the first
   *  scans' records, until the first two are placed again (placeFirstAgain). */
  std::vector<FirstSweep> first_sweeps_;
  std::vector<ScanRecord> settling_; ///< see first_sweeps_
  Poses front_end_poses_;
  std::vector<ScanReport> reports_;
  StageTimes times_;
  int relaxations_ = 0;
  std::size_t revisit_links_ = 0; ///< revisitLinks()
  std::size_t last_loop_scan_ = 0;
  bool has_odometry_ = false;
  std::optional<double> last_stamp_; ///< the previous scan's, if stamps are given
  std::size_t first_index_ = 0;
  std::size_t tracked_ = 0; ///< scans through track()
};

} // namespace slam
} // namespace pcl_parallel
