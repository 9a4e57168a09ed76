/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/filters/voxel_grid.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/registration/adaptive_threshold.h>
#include <pcl_parallel/slam/deskewer.h>
#include <pcl_parallel/slam/matcher.h>
#include <pcl_parallel/slam/motion_model.h>
#include <pcl_parallel/slam/pipeline.h>
#include <pcl_parallel/slam/pose_guess.h>
#include <pcl_parallel/slam/preprocess.h>
#include <pcl_parallel/slam/reducer.h>
#include <pcl_parallel/slam/sweep_path.h>

#include <pcl/common/time.h>
#include <pcl/common/transforms.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <iterator>
#include <stdexcept>
#include <string>
#include <utility>

namespace pcl_parallel {
namespace slam {

namespace {
/** A sweep's path in this many pieces of constant velocity: a hand-held scanner's turn
 *  speeds up and slows within a sweep (docs/design.md, "A sweep's path"). */
constexpr int kSweepPieces = 4;
/** The sweep's seconds the path's prior takes where the scans have no stamps and no
 *  sweep period is set: the 10 Hz of most spinning LiDARs (KITTI's HDL-64E, Ouster's and
 *  Hesai's defaults). */
constexpr double kUnstampedSweepSeconds = 0.1;
/** Without odometry, the first two scans are placed again once this many are matched:
 *  the map of the others then holds scans deskewed along their paths. */
constexpr std::size_t kSettlingScans = 4;
} // namespace

/** The front end's stages, in the order a scan passes them. */
struct Pipeline::Stages {
  explicit Stages(const Parameters& p)
      : motion(p.deskew.sweep_period, p.reduction.voxel_size)
      , deskewer(
            p.deskew.enabled, p.deskew.sweep_clockwise, p.reduction.voxel_size, p.num_threads)
      , reducer(p)
      , matcher(p)
      , guess(p, matcher, reducer, motion)
  {}
  MotionModel motion;
  Deskewer deskewer;
  Reducer reducer;
  Matcher matcher;
  PoseGuess guess;
};

Pipeline::Pipeline(const Parameters& params)
    : params_(params)
{}

Pipeline::Pipeline(const Parameters& params, double median_range, std::size_t first_index)
    : params_(params)
    , first_index_(first_index)
{
  start(median_range);
}

Pipeline::~Pipeline() = default;

void
Pipeline::start(double median_range)
{
  resolved_ = resolve(params_, median_range);
  stages_.reset(new Stages(resolved_));
  loops_.reset(new LoopCloser(resolved_));
}

void
Pipeline::setExchange(std::shared_ptr<ScanExchange> exchange)
{
  if (!loops_)
    throw std::logic_error("Pipeline::setExchange: construct with the median range");
  loops_->setExchange(std::move(exchange));
}

std::size_t
Pipeline::addScan(const Cloud& scan,
                  const std::optional<Pose>& odometry,
                  std::optional<double> stamp,
                  const std::vector<double>& point_times)
{
  for (ScanRecord& r : track(scan, odometry, stamp, point_times))
    addTracked(std::move(r));
  return tracked_ - 1;
}

std::size_t
Pipeline::addTracked(ScanRecord scan)
{
  const Pose pose = scan.pose;
  return addToGraph(std::move(scan), pose);
}

std::vector<ScanRecord>
Pipeline::track(const Cloud& scan,
                const std::optional<Pose>& odometry,
                std::optional<double> stamp,
                const std::vector<double>& point_times)
{
  const pcl::StopWatch start;
  std::vector<float> sweep_times;
  const Cloud::Ptr cropped = admit(scan, odometry, stamp, point_times, sweep_times);
  times_.preprocess += start.getTimeSeconds();

  // Front end: predict, deskew, reduce, guess, match (paper Sec. II; KISS-ICP Sec. III).
  const pcl::StopWatch stage;
  Stages& s = *stages_;
  ScanRecord r;
  r.index = first_index_ + tracked_;
  r.report.points = scan.size();
  const Pose before = s.motion.lastPose(); // after any loop correction
  const MotionPrediction m = s.motion.predict(odometry, stamp);
  r.prediction = r.pose = m.pose;
  if (m.first) {
    s.deskewer.holdFirst(*cropped, sweep_times);
    if (!odometry && s.deskewer.enabled())
      first_sweeps_.push_back({cropped, sweep_times});
  }
  else if (s.deskewer.holdsFirst() && odometry) // the first step is known: deskew the first
    keepFirstAgain(m.sweep);
  r.scan = reduce(*cropped, sweep_times, m.sweep);
  Cloud::Ptr source = s.reducer.source(r.scan);
  if (!m.first && s.matcher.hasTarget() && !source->empty())
    match(r, source, *cropped, sweep_times, m, odometry.has_value());
  r.report.source_points = source->size();
  if (s.deskewer.holdsFirst() && !m.first) { // both matched as they came, neither deskewed
    const Pose sweep = s.motion.sweepOf(s.motion.stepTo(r.pose, m), m);
    keepFirstAgain(sweep);
    r.scan = reduce(*cropped, sweep_times, sweep);
    if (!first_sweeps_.empty()) {
      first_sweeps_.front().sweep = sweep, first_sweeps_.front().gap = m.gap;
      first_sweeps_.push_back({cropped, sweep_times, sweep, m.gap});
    }
  }
  s.motion.update(r.pose, m, stamp);
  s.reducer.describe(r.scan);
  s.matcher.keep(r.scan, r.pose, static_cast<std::uint32_t>(s.motion.scans()));
  reportMatch(r, before);
  times_.front_end += stage.getTimeSeconds();
  r.report.seconds = start.getTimeSeconds();
  ++tracked_;
  return release(std::move(r));
}

Cloud::Ptr
Pipeline::admit(const Cloud& scan,
                const std::optional<Pose>& odometry,
                std::optional<double> stamp,
                const std::vector<double>& point_times,
                std::vector<float>& sweep_times)
{
  const std::size_t index = first_index_ + tracked_;
  if (odometry && !odometry->allFinite())
    throw std::invalid_argument("scan " + std::to_string(index) +
                                ": odometry pose is not finite");
  if (tracked_ > 0 && odometry.has_value() != has_odometry_)
    throw std::invalid_argument("scan " + std::to_string(index) +
                                ": odometry given for some scans but not for others");
  checkStamp(index, stamp);
  if (!point_times.empty())
    requireOnePerPoint(scan, point_times.size(), "scan " + std::to_string(index));
  if (!std::all_of(
          point_times.begin(), point_times.end(), [](double t) { return std::isfinite(t); }))
    throw std::invalid_argument("scan " + std::to_string(index) +
                                ": a point time is not finite");
  has_odometry_ = odometry.has_value();
  last_stamp_ = stamp;
  // Sweep times over the whole scan as given, then cropped with their points.
  const std::vector<float> fractions = sweepTimes(point_times);
  const ReductionParameters& range = params_.reduction;
  const Cloud::Ptr cropped =
      fractions.empty() ? cropRange(scan, range.min_range, range.max_range, params_.num_threads)
                        : cropRange(scan,
                                    range.min_range,
                                    range.max_range,
                                    fractions,
                                    sweep_times,
                                    params_.num_threads);
  requirePointsInRange(*cropped, index);
  requireScannerFrame(*cropped, "scan " + std::to_string(index), params_.num_threads);
  if (!stages_) // lengths from the first scan
    this->start(medianRange(*cropped));
  return cropped;
}

ReducedScan
Pipeline::reduce(const Cloud& scan,
                 const std::vector<float>& sweep_times,
                 const Pose& sweep) const
{
  return stages_->reducer.reduce(*stages_->deskewer.deskew(scan, sweep_times, sweep));
}

void
Pipeline::match(ScanRecord& r,
                Cloud::Ptr& source,
                const Cloud& scan,
                const std::vector<float>& sweep_times,
                const MotionPrediction& m,
                bool odometry)
{
  Stages& s = *stages_;
  const Pose& at = s.motion.lastPose(); // the previous scan's
  r.report.gate = s.matcher.gate();
  bool sample_of_scan = true; // source is r.scan's own registered sample
  const Pose start = guessStart(r, source, sweep_times, m, odometry, sample_of_scan);
  const Pose& prior_mean = PoseGuess::priorMean(r, start);
  std::optional<Pose> matched = s.matcher.match(source, start, prior_mean, at);
  if (matched && s.deskewer.enabled() && !s.deskewer.holdsFirst())
    matched =
        deskewAgain(r, source, scan, sweep_times, m, *matched, prior_mean, sample_of_scan);
  r.report.converged = matched.has_value();
  if (!matched)
    return;
  // Constant velocity compounds rounding, and odometry read from text carries its digits'
  // error: the pose is kept a rotation.
  r.pose = orthonormalized(*matched);
  s.matcher.measure(r, source);
}

Pose
Pipeline::guessStart(ScanRecord& r,
                     Cloud::Ptr& source,
                     const std::vector<float>& sweep_times,
                     const MotionPrediction& m,
                     bool odometry,
                     bool& sample_of_scan)
{
  Stages& s = *stages_;
  // Without odometry a start implies its own motion, and so its own deskewing (a turn the
  // prediction missed bends the scan as much as it moves it). A registered sample is
  // deskewed again by its points' azimuths; scans with per-point times keep the
  // prediction's deskewing until deskewAgain.
  if (odometry || !s.deskewer.enabled() || s.deskewer.holdsFirst() || !sweep_times.empty())
    return s.guess.guess(source, r.scan, odometry, r);
  // A start's sweep is its own step, not carried to the step's end by the change since
  // the step before as a match's is (sweepOfMatch): that change is the start's guess, and
  // carrying it amplifies its error (a corner's 50 degree start after a 14 degree step
  // would deskew by 68 degrees a sweep).
  const auto deskewed_for = [&](const Cloud& cloud, const Pose& start) -> Cloud::Ptr {
    const Pose sweep = s.motion.sweepOf(s.motion.stepTo(start, m), m);
    if (!s.deskewer.needsAgain(m.sweep, sweep, *r.scan.reduced))
      return nullptr;
    return s.deskewer.again(cloud, m.sweep, sweep);
  };
  const Pose start = s.guess.guess(source, r.scan, odometry, r, deskewed_for);
  // The map match takes the start's deskewing, carried as a match's (sweepOfMatch), where
  // it moves the scan beyond the final gate; below, deskewAgain's exact deskewing by the
  // match does better.
  const Pose sweep = s.motion.sweepOfMatch(start, m);
  if (Deskewer::movesBeyond(
          m.sweep, sweep, *r.scan.reduced, resolved_.matcher.final_correspondence_distance)) {
    source = s.deskewer.again(*source, m.sweep, sweep);
    sample_of_scan = false;
  }
  return start;
}

std::optional<Pose>
Pipeline::deskewAgain(ScanRecord& r,
                      Cloud::Ptr& source,
                      const Cloud& scan,
                      const std::vector<float>& sweep_times,
                      const MotionPrediction& m,
                      Pose matched,
                      const Pose& prior_mean,
                      bool sample_of_scan)
{
  Stages& s = *stages_;
  const Pose& at = s.motion.lastPose();
  const Pose sweep = s.motion.sweepOfMatch(matched, m);
  if (s.deskewer.needsAgain(m.sweep, sweep, *r.scan.reduced)) {
    // The matched step's sweep may differ much from the prediction's (a wide match); the
    // path's from the step's little (a refinement).
    ReducedScan again = reduce(scan, sweep_times, sweep);
    const Cloud::Ptr again_source = s.reducer.source(again);
    if (const auto rematched = s.matcher.match(again_source, matched, prior_mean, at)) {
      r.scan = std::move(again), source = again_source;
      r.report.deskewed_again = true;
      if (const auto along =
              followPath(r, source, scan, sweep_times, sweep, *rematched, prior_mean, m.gap))
        return along;
      matched = *rematched;
    }
  }
  else if (sample_of_scan) { // the matcher's last pICP is the kept scan's
    return matched;
  }
  if (!sample_of_scan && !r.report.deskewed_again) // the guess's deskewing, not the scan's
    source = s.reducer.source(r.scan);
  return s.matcher.refine(source, matched, prior_mean, at); // its pairs and Hessian kept
}

std::optional<Pipeline::AlongPath>
Pipeline::alongPath(Matcher& matcher,
                    const Cloud& scan,
                    const std::vector<float>& sweep_times,
                    const Pose& sweep,
                    const Pose& matched,
                    const Pose& prior_mean,
                    const Pose& at,
                    double gap) const
{
  // The path's prior is in the sweep's time: the sweep period, else the time since the
  // previous scan, else a spinning LiDAR's common 10 Hz.
  const double seconds = resolved_.deskew.sweep_period > 0.0 ? resolved_.deskew.sweep_period
                         : gap > 0.0                         ? gap
                                                             : kUnstampedSweepSeconds;
  const Stages& s = *stages_;
  const std::vector<float> times = s.deskewer.sweepTimesOf(scan, sweep_times);
  const auto [sample, sample_times] =
      s.deskewer.timedSample(scan, times, resolved_.reduction.source_voxel_size);
  SweepPath path(matched, sweep, kSweepPieces);
  if (!matcher.fitPath(
          path, *sample, sample_times, SweepPathPrior::forSweep(seconds, kSweepPieces)))
    return std::nullopt;
  AlongPath along;
  along.scan = s.reducer.reduce(*deskewAlong(scan, times, path, resolved_.num_threads));
  along.source = s.reducer.source(along.scan);
  const auto refined = matcher.refine(along.source, path.mid(), prior_mean, at);
  if (!refined)
    return std::nullopt;
  along.pose = *refined;
  return along;
}

std::optional<Pose>
Pipeline::followPath(ScanRecord& r,
                     Cloud::Ptr& source,
                     const Cloud& scan,
                     const std::vector<float>& sweep_times,
                     const Pose& sweep,
                     const Pose& matched,
                     const Pose& prior_mean,
                     double gap)
{
  Stages& s = *stages_;
  std::optional<AlongPath> along = alongPath(
      s.matcher, scan, sweep_times, sweep, matched, prior_mean, s.motion.lastPose(), gap);
  if (!along)
    return std::nullopt;
  r.scan = std::move(along->scan), source = along->source;
  return along->pose;
}

void
Pipeline::keepFirstAgain(const Pose& sweep)
{
  Stages& s = *stages_;
  ReducedScan first = s.reducer.reduce(*s.deskewer.releaseFirst(sweep));
  s.reducer.describe(first);
  s.matcher.clearMap(); // of the first scan alone, at its pose
  s.matcher.keep(first, s.motion.lastPose(), 1);
  if (held_) { // not when drained (finish) before
    held_->report.reduced_points = first.reduced->size();
    held_->scan = std::move(first);
  }
}

void
Pipeline::reportMatch(ScanRecord& r, const Pose& before) const
{
  // The front end's own step: chained without the loop closures' corrections.
  r.step = tracked_ == 0 ? r.pose : Pose(before.inverse() * r.pose);
  r.report.reduced_points = r.scan.reduced->size();
  const double range = resolved_.median_range;
  r.report.correction =
      registration::motionDisplacement(r.prediction.inverse() * r.pose, range);
  if (tracked_ > 0)
    r.report.predicted_step =
        registration::motionDisplacement(before.inverse() * r.prediction, range);
}

std::vector<ScanRecord>
Pipeline::release(ScanRecord r)
{
  std::vector<ScanRecord> out;
  if (stages_->deskewer.holdsFirst()) {
    held_ = std::move(r);
    return out;
  }
  if (held_) {
    out.push_back(std::move(*held_));
    held_.reset();
  }
  out.push_back(std::move(r));
  if (first_sweeps_.empty())
    return out;
  std::move(out.begin(), out.end(), std::back_inserter(settling_));
  out.clear();
  if (settling_.size() < kSettlingScans)
    return out;
  placeFirstAgain();
  first_sweeps_.clear();
  out.swap(settling_);
  return out;
}

void
Pipeline::placeFirstAgain()
{
  // The second scan was matched to the first sweep as recorded, and the first step's
  // velocity deskewed both: a bent pair that agrees with itself. The scans after them
  // followed their paths; against those, each of the two is placed along its own.
  const Pose first = settling_[0].pose;
  placeAgain(1);
  placeAgain(0);
  const Pose correction = first * settling_[0].pose.inverse();
  for (ScanRecord& r : settling_)
    r.pose = correction * r.pose;
  settling_[0].pose = first;
  for (std::size_t j = 1; j < settling_.size(); ++j)
    settling_[j].step = settling_[j - 1].pose.inverse() * settling_[j].pose;
  Stages& s = *stages_;
  s.motion.applyCorrection(correction);
  s.matcher.clearMap();
  for (std::size_t j = 0; j < settling_.size(); ++j)
    s.matcher.keep(settling_[j].scan, settling_[j].pose, static_cast<std::uint32_t>(j + 1));
}

void
Pipeline::placeAgain(std::size_t j)
{
  // The motion prior centred where the front end put the scan: along a road or a
  // corridor the map fixes no position along it, and nothing else would hold it.
  Stages& s = *stages_;
  Matcher others(resolved_);
  for (std::size_t k = 0; k < settling_.size(); ++k)
    if (k != j)
      others.keep(settling_[k].scan, settling_[k].pose, static_cast<std::uint32_t>(k + 1));
  const FirstSweep& f = first_sweeps_[j];
  ScanRecord& r = settling_[j];
  const Pose& near = settling_[j == 0 ? 1 : j - 1].pose;
  const Cloud::Ptr source = s.reducer.source(reduce(*f.points, f.times, f.sweep));
  const std::optional<Pose> matched = others.match(source, r.pose, r.pose, near);
  if (!matched)
    return;
  std::optional<AlongPath> along =
      alongPath(others, *f.points, f.times, f.sweep, *matched, *matched, near, f.gap);
  if (!along)
    return;
  s.reducer.describe(along->scan);
  r.scan = std::move(along->scan);
  r.pose = orthonormalized(along->pose);
  r.report.reduced_points = r.scan.reduced->size();
}

std::vector<ScanRecord>
Pipeline::drain()
{
  std::vector<ScanRecord> out; // a sequence too short to settle, as matched
  out.swap(settling_);
  first_sweeps_.clear();
  if (held_)
    out.push_back(std::move(*held_));
  held_.reset();
  return out;
}

void
Pipeline::correctFrontEnd(const Pose& pose)
{
  // The previous scan, kept in its own frame, moves with the last pose.
  const Pose correction = pose * stages_->motion.lastPose().inverse();
  stages_->motion.applyCorrection(correction);
  stages_->matcher.applyCorrection(correction);
}

std::optional<double>
odometryDisagreement(const std::vector<ScanReport>& reports, double min_step)
{
  // The first scan has no step; the window's end, once.
  const std::size_t end = std::min(reports.size(), 1 + kOdometryDisagreementSteps);
  std::vector<double> corrections, steps;
  for (std::size_t i = 1; i < end; ++i) {
    corrections.push_back(reports[i].correction);
    steps.push_back(reports[i].predicted_step);
  }
  if (steps.size() < 5)
    return std::nullopt;
  const double step = median(steps);
  if (!(step >= min_step))
    return std::nullopt;
  return median(std::move(corrections)) / step;
}

Cloud::Ptr
mapFrame(const Cloud& scan,
         const std::vector<double>& point_times,
         const Poses& poses,
         const std::vector<double>& stamps,
         std::size_t k,
         const Parameters& p)
{
  if (!p.deskew.enabled)
    return Cloud::Ptr(new Cloud(scan));
  if (!point_times.empty())
    requireOnePerPoint(scan, point_times.size(), "scan " + std::to_string(k));
  return deskewSweep(scan,
                     sweepTimes(point_times),
                     sweepMotionAt(poses, stamps, k, p.deskew.sweep_period),
                     p.deskew.sweep_clockwise,
                     p.num_threads);
}

void
Pipeline::checkStamp(std::size_t index, const std::optional<double>& stamp) const
{
  const std::string scan = "scan " + std::to_string(index);
  if (stamp && !std::isfinite(*stamp))
    throw std::invalid_argument(scan + ": time stamp is not finite");
  if (tracked_ > 0 && stamp.has_value() != last_stamp_.has_value())
    throw std::invalid_argument(scan + ": time stamps given for some scans but not for others");
  if (!params_.deskew.enabled || params_.deskew.sweep_period <= 0.0)
    return;
  if (!stamp)
    throw std::invalid_argument(scan + ": deskewing by a sweep period needs time stamps");
  if (last_stamp_ && !(*stamp > *last_stamp_))
    throw std::invalid_argument(scan + ": time stamp " + std::to_string(*stamp) +
                                " is not after the previous scan's (" +
                                std::to_string(*last_stamp_) + ")");
}

std::size_t
Pipeline::addMatched(ScanRecord scan)
{
  if (!loops_)
    throw std::logic_error("Pipeline::addMatched: construct with the median range");
  const Pose pose = size() == 0 ? scan.pose : Pose(poses().back() * scan.step);
  return addToGraph(std::move(scan), pose);
}

std::size_t
Pipeline::addToGraph(ScanRecord scan, const Pose& pose)
{
  const pcl::StopWatch start;
  const std::size_t index = size();
  front_end_poses_.push_back(index == 0 ? scan.step
                                        : Pose(front_end_poses_.back() * scan.step));
  ScanReport& report = scan.report;

  // The pose graph, loops by pose distance (Sec. VI-C), pLUM when a loop closes (Sec. V).
  pcl::StopWatch stage;
  loops_->addScan(scan.scan.reduced,
                  pose,
                  std::move(scan.scan.normals),
                  scan.information,
                  scan.information_pairs,
                  report.map_scans,
                  report.reduced_points,
                  std::move(scan.scan.tree));
  const LoopClosureParameters& l = resolved_.loops;
  if (l.enabled) {
    report.loops = loops_->detect();
    const auto found = std::find_if(
        report.loops.begin(), report.loops.end(), [](const auto& c) { return c.accepted; });
    times_.loop_detection += stage.getTimeSeconds();
    if (found != report.loops.end()) {
      // A new loop (not the continuation of one just closed) whose error shows in the map
      // is relaxed at once; the others wait for finish().
      const bool new_loop =
          last_loop_scan_ == 0 ||
          index - last_loop_scan_ > static_cast<std::size_t>(l.min_separation);
      const bool visible = found->error > l.overlap_distance;
      last_loop_scan_ = index;
      stage.reset();
      const bool relax = new_loop && visible && l.relax_each_loop;
      if (relax) {
        report.lum_iterations = loops_->relax(l.lum_iterations_per_loop);
        ++relaxations_;
      }
      if (relax || found->distributed) // the front end continues from the moved pose
        correctFrontEnd(loops_->poses().back());
      times_.loop_closing += stage.getTimeSeconds();
    }
  }
  report.seconds += start.getTimeSeconds();
  reports_.push_back(std::move(report));
  return index;
}

void
Pipeline::finish()
{
  for (ScanRecord& r : drain())
    addTracked(std::move(r));
  if (!loops_ || !params_.loops.enabled)
    return;
  const bool any_loop = std::any_of(
      loops_->links().begin(), loops_->links().end(), [](const Link& l) { return l.loop; });
  if (any_loop)
    relaxAtEnd();
  for (int round = 0; round < resolved_.loops.revisit_rounds; ++round) {
    const pcl::StopWatch stage;
    const std::size_t linked = loops_->linkRevisits();
    times_.loop_detection += stage.getTimeSeconds();
    revisit_links_ += linked;
    if (linked == 0)
      break;
    relaxAtEnd();
  }
  const std::vector<double> chi2 = loops_->sequenceChi2();
  for (std::size_t i = 0; i < reports_.size() && i < chi2.size(); ++i)
    reports_[i].sequence_chi2 = chi2[i];
}

void
Pipeline::relaxAtEnd()
{
  const pcl::StopWatch stage;
  const int iterations = loops_->relax();
  ++relaxations_;
  if (!reports_.empty())
    reports_.back().lum_iterations += iterations;
  times_.loop_closing += stage.getTimeSeconds();
}

const Poses&
Pipeline::poses() const
{
  static const Poses none;
  return loops_ ? loops_->poses() : none;
}

const std::vector<Link>&
Pipeline::links() const
{
  static const std::vector<Link> none;
  return loops_ ? loops_->links() : none;
}

Cloud::ConstPtr
Pipeline::reducedScan(std::size_t i) const
{
  return loops_->scan(i);
}

RevisitConsistency
Pipeline::consistency(bool front_end) const
{
  std::vector<Cloud::ConstPtr> scans(size());
  for (std::size_t i = 0; i < scans.size(); ++i)
    scans[i] = reducedScan(i);
  return revisitConsistency(scans, front_end ? frontEndPoses() : poses(), resolved_);
}

Cloud::Ptr
Pipeline::map(double voxel_size) const
{
  const MapScanSource kept = [this](std::size_t i, unsigned) { return loops_->scan(i); };
  return assembleMap(kept, poses(), 0, size(), voxel_size, params_.num_threads);
}

namespace {

/** The map pass prepares at most this many scans at once, and at most about this many
 *  points (~80 bytes each while grouped): a terrestrial scanner's scans of tens of millions
 *  of points go one at a time, each on every thread. */
constexpr unsigned kMapBatch = 16;
constexpr std::size_t kMapPointsInFlight = 4000000;

/** Every point of the scans, moved. */
Cloud::Ptr
allPoints(const MapScanSource& read,
          const Poses& poses,
          std::size_t begin,
          std::size_t end,
          unsigned num_threads,
          const std::function<void(int, int)>& step)
{
  Cloud::Ptr map(new Cloud);
  const int n = static_cast<int>(end - begin);
  for (int k = 0; k < n; ++k) {
    if (const Cloud::ConstPtr scan = read(begin + k, num_threads)) {
      Cloud moved;
      pcl::transformPointCloud(*scan, moved, poses[begin + k]);
      *map += moved;
    }
    if (step)
      step(k + 1, n);
  }
  return map;
}

} // namespace

Cloud::Ptr
assembleMap(const MapScanSource& read,
            const Poses& poses,
            std::size_t begin,
            std::size_t end,
            double voxel_size,
            unsigned num_threads,
            const std::function<void(int, int)>& step)
{
  end = std::max(begin, std::min(end, poses.size()));
  if (!(voxel_size > 0.0)) // every point, as asked
    return allPoints(read, poses, begin, end, num_threads, step);
  // A batch of scans is prepared at once, one per thread, then added in order, so every
  // voxel's sum runs as in a scan-by-scan pass. The batch is sized by the largest scan
  // read so far; the first scan goes alone.
  filters::VoxelCentroidMap map(voxel_size, num_threads);
  const unsigned threads = resolveNumberOfThreads(num_threads);
  const int n = static_cast<int>(end - begin);
  std::size_t largest = 0;
  for (int first = 0; first < n;) {
    const std::size_t fit = largest > 0 ? kMapPointsInFlight / largest : 1;
    const int count =
        static_cast<int>(std::min<std::size_t>({std::max<std::size_t>(fit, 1),
                                                std::min(threads, kMapBatch),
                                                static_cast<std::size_t>(n - first)}));
    std::vector<filters::VoxelCentroidMap::Grouped> grouped(count);
    std::vector<std::size_t> points(count, 0);
    std::vector<std::exception_ptr> errors(count);
    const auto prepare = [&](std::size_t i, unsigned inner) {
      const std::size_t k = begin + first + i;
      if (const Cloud::ConstPtr scan = read(k, inner)) {
        points[i] = scan->size();
        grouped[i] = map.group(*scan, poses[k], inner);
      }
    };
    if (count == 1)
      prepare(0, threads);
    else
      parallelFor(static_cast<std::size_t>(count),
                  static_cast<unsigned>(count),
                  1,
                  [&](std::size_t i0, std::size_t i1) {
                    for (std::size_t i = i0; i < i1; ++i)
                      try {
                        prepare(i, 1);
                      }
                      catch (...) { // rethrown below, the first scan's first: as a serial pass
                        errors[i] = std::current_exception();
                      }
                  });
    for (int i = 0; i < count; ++i) {
      if (errors[i])
        std::rethrow_exception(errors[i]);
      map.add(std::move(grouped[i]));
      largest = std::max(largest, points[i]);
      if (step)
        step(first + i + 1, n);
    }
    first += count;
  }
  return map.centroids();
}

std::size_t
Pipeline::bytesPerScan() const
{
  return loops_ ? loops_->bytesPerScan() + sizeof(Pose) + sizeof(ScanReport) : 0;
}

} // namespace slam
} // namespace pcl_parallel
