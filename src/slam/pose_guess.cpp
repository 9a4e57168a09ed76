/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/registration/adaptive_threshold.h>
#include <pcl_parallel/slam/correlative_search.h>
#include <pcl_parallel/slam/matcher.h>
#include <pcl_parallel/slam/motion_model.h>
#include <pcl_parallel/slam/overlap.h>
#include <pcl_parallel/slam/pose_guess.h>
#include <pcl_parallel/slam/preprocess.h>
#include <pcl_parallel/slam/reducer.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <utility>

namespace pcl_parallel {
namespace slam {

namespace {

/** Without odometry, a match to the previous scan that overlaps it less than this
 *  fraction of the recent matches' median overlap is searched for (pose_search) ... */
constexpr double kSearchOverlapRatio = 0.7;
/** ... the recent matches being the last this many. */
constexpr std::size_t kSearchOverlapHistory = 20;
/** The search's match replaces the prediction's only if it overlaps the previous scan by
 *  this factor more: along a street or a corridor, shifted matches overlap alike. */
constexpr double kSearchMargin = 1.25;
/** A search candidate is matched on the sample deskewed by its own motion at most this
 *  many times (PoseGuess::searchPose). */
constexpr int kOwnDeskewingRounds = 3;
/** The pose search works on points whose normal lies more than 45 degrees from up
 *  (walls, poles, facades) where a scan has at least this many, else on all. */
constexpr std::size_t kMinUprightPoints = 100;
/** A hypothesis that fits better does not replace the leader if it puts more of its
 *  points into the space the previous scan saw through by this many standard errors of
 *  the difference (the conflicts as counts among the source's n points: sqrt((a + b) / n)). */
constexpr double kConflictSignificance = 3.0;

/** The points whose normal lies more than 45 degrees from `up`: walls, poles, facades.
 *  Floor and ceiling fix no horizontal position, and where they dominate a scan (a 3D
 *  scanner indoors) the search would favour the poses that overlap the most floor. */
Cloud::Ptr
upright(const MapCloud& points, const Eigen::Vector3d& up)
{
  const Eigen::Vector3f u = up.normalized().cast<float>();
  Cloud::Ptr out(new Cloud);
  for (const MapPoint& p : points)
    if (const Eigen::Vector3f n = p.getNormalVector3fMap();
        n.allFinite() && std::abs(n.dot(u)) < M_SQRT1_2)
      out->push_back(PointT(p.x, p.y, p.z));
  return out;
}

/** Every k-th point, about `count` of them. */
Cloud::Ptr
everyKth(const Cloud& points, std::size_t count)
{
  const std::size_t k =
      std::max<std::size_t>(1, points.size() / std::max<std::size_t>(1, count));
  Cloud::Ptr out(new Cloud);
  for (std::size_t i = 0; i < points.size(); i += k)
    out->push_back(points[i]);
  return out;
}

} // namespace

PoseGuess::PoseGuess(const Parameters& resolved,
                     Matcher& matcher,
                     const Reducer& reducer,
                     const MotionModel& motion)
    : params_(resolved)
    , matcher_(matcher)
    , reducer_(reducer)
    , motion_(motion)
{}

Pose
PoseGuess::guess(const Cloud::ConstPtr& source,
                 ReducedScan& scan,
                 bool odometry,
                 ScanRecord& r,
                 const StartDeskew& deskew)
{
  // To the local map: from the match to the previous scan (guess_from_previous_scan); to
  // the previous scan: the best start refined there. With odometry, its step.
  const bool from_previous =
      params_.matcher.target == MatchTarget::kLocalMap
          ? params_.guess.guess_from_previous_scan && !matcher_.previous().empty()
          : params_.guess.speed_hypotheses || params_.guess.pose_search;
  if (odometry || !from_previous)
    return r.prediction;
  const std::optional<Pose> own =
      matcher_.alignToPrevious(source, r.prediction, false, nullptr, motion_.lastPose());
  const std::optional<Pose> better = betterGuess(source, scan, own, r, deskew);
  return better ? *better : own.value_or(r.prediction);
}

const Pose&
PoseGuess::priorMean(const ScanRecord& r, const Pose& start)
{
  return std::isfinite(r.report.start_heading) ? start : r.prediction;
}

PoseGuess::Hypotheses
PoseGuess::hypotheses(const Cloud& source, const Pose& prediction) const
{
  Hypotheses h;
  if (!params_.guess.speed_hypotheses || matcher_.previous().empty() || source.empty())
    return h;
  const double same = sameSolution();
  const Pose step = motion_.lastPose().inverse() * prediction;
  // Speed: along the predicted step, or the way the scanner last moved (in its frame).
  const Eigen::Vector3d t = step.topRightCorner<3, 1>();
  h.travel = t.norm() >= params_.reduction.voxel_size ? t.normalized() : motion_.heading();
  h.speed = t.dot(h.travel);
  const double sigma = matcher_.gate() / 3.0;
  if (!h.travel.isZero() && 2.0 * sigma > same)
    h.sigma = sigma;
  // Turn rate: the predicted turn stopped or doubled moves the scan's points at its median
  // range by the turn's angle times that range; tried where that leaves the refinement gate.
  h.range = medianRange(source);
  const Eigen::AngleAxisd turn(Eigen::Matrix3d(step.topLeftCorner<3, 3>()));
  if (turn.angle() * h.range > same)
    h.turn = turn;
  return h;
}

double
PoseGuess::sameSolution() const
{
  // Starts or matches closer than the refinement gate lie in one basin.
  return std::max(params_.matcher.final_correspondence_distance, params_.reduction.voxel_size);
}

bool
PoseGuess::atPreviousScan(const Pose& local) const
{
  return local.topRightCorner<3, 1>().norm() <= sameSolution();
}

bool
PoseGuess::isRival(const Pose& leader, const Pose& other, double range) const
{
  // A match where the best so far ended is the same solution; one that ends where the
  // previous scan was taken shares its sampling pattern, so its fitness and overlap are
  // no measure against a match that moves (docs/design.md, "Standing still").
  return registration::motionDisplacement(leader.inverse() * other, range) > sameSolution() &&
         !(atPreviousScan(other) && !atPreviousScan(leader));
}

std::optional<Pose>
PoseGuess::bestHypothesis(const Cloud::ConstPtr& source,
                          const Pose& prediction,
                          const std::optional<Pose>& own,
                          const Hypotheses& h,
                          ScanRecord& r,
                          const StartDeskew& deskew)
{
  const double gate = matcher_.gate(), same = sameSolution();
  const Pose& at = motion_.lastPose(); // the previous scan's pose
  // Fitness over the pairs within sqrt(gate): PCL's max_range is a squared distance, and
  // the gate (metres) goes in as it (docs/design.md, "Speed hypotheses", says why).
  double best = own ? matcher_.previousFitness(gate) : std::numeric_limits<double>::infinity();
  std::optional<Pose> winner;
  const Pose to_previous = at.inverse(); // rivals are compared in its frame
  // A better fit is no measure where it contradicts the previous scan more: the stop
  // fits better by the shared sampling pattern, yet puts the far walls of the corridor
  // into its open space (docs/design.md, "Standing still").
  std::unique_ptr<FreeSpace> seen;
  const auto contradictsMore = [&](const Pose& other, const Pose& leader) {
    if (!seen)
      seen.reset(new FreeSpace(*matcher_.previous().points, params_.guess.up));
    const double a = seen->conflicts(*source, other, same),
                 b = seen->conflicts(*source, leader, same);
    return a - b > kConflictSignificance * std::sqrt((a + b) / source->size());
  };
  // The prior stays at the prediction: what the motion model believes, not the start.
  // A start's match is judged on the sample deskewed by the motion it implies: one
  // deskewed by the prediction's motion is bent against any other start.
  const auto tryStart = [&](const Pose& start, double offset, double turn) {
    const Cloud::Ptr own_sample = deskew ? deskew(*source, start) : nullptr;
    const std::optional<Pose> other = matcher_.alignToPrevious(
        own_sample ? Cloud::ConstPtr(own_sample) : source, start, false, &prediction, at);
    if (!other)
      return;
    const double fitness = matcher_.previousFitness(gate);
    const std::optional<Pose>& leader = winner ? winner : own;
    if (leader && !isRival(to_previous * *leader, to_previous * *other, h.range))
      return;
    if (fitness < best &&
        !(leader && contradictsMore(to_previous * *other, to_previous * *leader))) {
      best = fitness;
      winner = other;
      r.report.start_offset = offset;
      r.report.start_turn = turn;
    }
  };
  for (const double k : {-2.0, -1.0, 1.0, 2.0})
    // Speed, not direction: a start behind the previous scan's position would reverse the
    // travel, and along a street it ends in a false fit behind (docs/design.md, "Standing
    // still").
    if (h.sigma > 0.0 && std::abs(k) * h.sigma > same && h.speed + k * h.sigma >= -same) {
      Pose start = prediction;
      start.topRightCorner<3, 1>() += at.topLeftCorner<3, 3>() * (k * h.sigma * h.travel);
      tryStart(start, k * h.sigma, 0.0);
    }
  if (h.turn.angle() > 0.0) {
    Pose step = at.inverse() * prediction;
    for (const double k : {-1.0, 1.0}) { // the predicted turn stopped, doubled
      step.topLeftCorner<3, 3>() =
          Eigen::AngleAxisd((1.0 + k) * h.turn.angle(), h.turn.axis()).toRotationMatrix();
      tryStart(at * step, 0.0, k);
    }
  }
  return winner;
}

std::optional<Pose>
PoseGuess::searchPose(const Cloud::ConstPtr& source,
                      ReducedScan& scan,
                      const std::optional<Pose>& own,
                      double range,
                      ScanRecord& r,
                      const StartDeskew& deskew)
{
  const PreviousScan& previous = matcher_.previous();
  if (!params_.guess.pose_search || previous.empty() || source->empty())
    return std::nullopt;
  const Pose& at = motion_.lastPose();
  // In the previous scan's frame: how much of it the prediction's match sees.
  const double same = sameSolution();
  const std::optional<Pose> own_local =
      own ? std::optional<Pose>(at.inverse() * *own) : std::nullopt;
  const double own_overlap =
      own_local ? overlap(*source, *own_local, *previous.index, same) : 0.0;
  // Searched only where the match looks wrong: the first, one that sees far less of the
  // previous scan than the recent matches did, or one where a turn hypothesis won (the
  // prediction missed the turn by its own size: a turn nothing predicted).
  if (!overlaps_.empty() && r.report.start_turn == 0.0 &&
      own_overlap >= kSearchOverlapRatio * median(overlaps_)) {
    keepOverlap(own_overlap);
    return std::nullopt;
  }
  r.report.pose_searched = true;
  CorrelativeSearchParameters search;
  search.cell = 2.0 * params_.reduction.voxel_size;
  search.num_threads = params_.num_threads;
  matcher_.usePrevious(source);
  if (!(range > 0.0))
    range = medianRange(*source);
  // Searched and judged on both scans' upright points where they have them. A candidate
  // must overlap the previous scan clearly more than `own`, and agree with it more:
  // overlap less conflicts (points in the space it saw through); of those, the one that
  // agrees most wins (docs/design.md, "Where the site repeats").
  reducer_.describe(scan);
  const Cloud& reduced = *scan.reduced;
  const Cloud::Ptr walls = upright(*scannerFrameCloud(scan), params_.guess.up);
  const Cloud::Ptr previous_walls = upright(*previous.cloud, params_.guess.up);
  const bool on_walls =
      walls->size() >= kMinUprightPoints && previous_walls->size() >= kMinUprightPoints;
  const Cloud::ConstPtr judged =
      on_walls ? Cloud::ConstPtr(everyKth(*walls, source->size())) : source;
  const FreeSpace seen(*previous.points, params_.guess.up);
  // A pose is judged on the scan deskewed by the motion it implies: a turn the prediction
  // missed bends the prediction's deskewing against the pose that catches it.
  const auto judge = [&](const Pose& local) {
    const Cloud::Ptr own_judged = deskew ? deskew(*judged, at * local) : nullptr;
    const Cloud& cloud = own_judged ? *own_judged : *judged;
    return std::make_pair(overlap(cloud, local, *previous.index, same),
                          seen.conflicts(cloud, local, same));
  };
  // A candidate's match on the sample deskewed by the motion it implies, until the match
  // stays in its basin (a few rounds: each deskewing follows the last match).
  const double gate = std::min(params_.matcher.max_correspondence_distance, 2.0 * search.cell);
  const auto alignFrom = [&](const Pose& start) {
    std::optional<Pose> m = matcher_.alignInPrevious(start, gate);
    for (int round = 0; m && deskew && round < kOwnDeskewingRounds; ++round) {
      const Cloud::Ptr own_sample = deskew(*source, at * *m);
      if (!own_sample)
        break;
      matcher_.usePrevious(own_sample);
      const std::optional<Pose> again = matcher_.alignInPrevious(*m, gate);
      const bool settled =
          again && registration::motionDisplacement(m->inverse() * *again, range) <= same;
      m = again;
      if (settled)
        break;
    }
    matcher_.usePrevious(source);
    return m;
  };
  const auto [own_agrees, own_conflicts] =
      own_local ? judge(*own_local) : std::make_pair(0.0, 0.0);
  const double own_net = own_agrees - own_conflicts;
  double best = -std::numeric_limits<double>::infinity();
  std::optional<Pose> winner;
  const Cloud& searched = on_walls ? *walls : reduced;
  for (const Pose& start : correlativeSearch(
           searched, on_walls ? *previous_walls : *previous.points, params_.guess.up, search)) {
    // From a candidate good to a cell: a gate of two cells, no prior (none predicted it).
    const std::optional<Pose> m = alignFrom(start);
    if (!m || (own_local && !isRival(*own_local, *m, range)))
      continue;
    const auto [agrees, conflicts] = judge(*m);
    if (agrees > kSearchMargin * own_agrees && agrees - conflicts > own_net &&
        agrees - conflicts > best) {
      best = agrees - conflicts;
      winner = *m;
      const Eigen::AngleAxisd turn(Eigen::Matrix3d(start.topLeftCorner<3, 3>()));
      r.report.start_heading =
          turn.axis().dot(params_.guess.up) < 0.0 ? -turn.angle() : turn.angle();
    }
  }
  keepOverlap(winner ? overlap(*source, *winner, *previous.index, same) : own_overlap);
  if (winner)
    winner = at * *winner;
  return winner;
}

void
PoseGuess::keepOverlap(double o)
{
  overlaps_.push_back(o);
  if (overlaps_.size() > kSearchOverlapHistory)
    overlaps_.erase(overlaps_.begin());
}

std::optional<Pose>
PoseGuess::betterGuess(const Cloud::ConstPtr& source,
                       ReducedScan& scan,
                       const std::optional<Pose>& own,
                       ScanRecord& r,
                       const StartDeskew& deskew)
{
  // A hypothesis' match where one fits better, the search's where even that looks wrong:
  // the search is the last resort, the costliest and the least local.
  std::optional<Pose> better;
  const Hypotheses h = hypotheses(*source, r.prediction);
  if (h.any())
    better = bestHypothesis(source, r.prediction, own, h, r, deskew);
  if (auto found = searchPose(source, scan, better ? better : own, h.range, r, deskew))
    better = found;
  return better;
}

} // namespace slam
} // namespace pcl_parallel
