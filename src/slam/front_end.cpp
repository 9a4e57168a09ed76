/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/filters/voxel_grid.h>
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/normal_estimation.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/registration/adaptive_threshold.h>
#include <pcl_parallel/registration/icp.h>
#include <pcl_parallel/search/kdtree.h>
#include <pcl_parallel/slam/correlative_search.h>
#include <pcl_parallel/slam/front_end.h>
#include <pcl_parallel/slam/overlap.h>
#include <pcl_parallel/slam/preprocess.h>

#include <pcl/common/transforms.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

namespace pcl_parallel {
namespace slam {

namespace {
using Icp = ParallelIterativeClosestPoint<PointT, MapPoint, float>;
} // namespace

struct FrontEnd::Registration {
  // The target's normals come with it (setUseTargetNormalFields): estimated once per scan.
  Icp icp;
  Icp to_previous; ///< the initial guess's match; its own object keeps icp's map tree
  std::unique_ptr<registration::AdaptiveThreshold> threshold;
};

namespace {

/** KISS-ICP's min motion for the adaptive threshold, in map voxels (0.1 m at 1 m). */
constexpr double kMinMotionVoxels = 0.1;
/** Deviations kept before the prior's spread is taken from them: σ from n samples is
 *  known to about 1/sqrt(2n), 16 % at 20. */
constexpr std::size_t kPriorSpreadSamples = 20;
/** Constant velocity in time scales the last step by gap / span, within [1/k, k]. A gap
 *  far longer than the last may hide a stop (keyframes taken by distance: a car waiting
 *  makes none), and a tenfold extrapolation puts the prediction out of pICP's reach
 *  (test_slam ConstantVelocityOverAnUnseenStop: 3 m ATE unbounded, 1.4 cm at k = 4).
 *  Keyframes of a steady drive taken by distance and by turn reach 1/4-4 (mulran). */
constexpr double kMaxVelocityScale = 4.0;

/** Without odometry, a match to the previous scan that overlaps it less than this
 *  fraction of the recent matches' median overlap is searched for (pose_search) ... */
constexpr double kSearchOverlapRatio = 0.7;
/** ... the recent matches being the last this many. */
constexpr std::size_t kSearchOverlapHistory = 20;
/** The search's match replaces the prediction's only if it overlaps the previous scan by
 *  this factor more: along a street or a corridor, shifted matches overlap alike. */
constexpr double kSearchMargin = 1.25;
/** The pose search works on points whose normal lies more than 45 degrees from up
 *  (walls, poles, facades) where a scan has at least this many, else on all. */
constexpr std::size_t kMinUprightPoints = 100;
/** A hypothesis that fits better does not replace the leader if it puts more of its
 *  points into the space the previous scan saw through by this many standard errors of
 *  the difference (the conflicts as counts among the source's n points: sqrt((a + b) / n)). */
constexpr double kConflictSignificance = 3.0;
/** A scan is deskewed again by its matched step where that moves its farthest point by
 *  more than this many voxels from where the predicted step put it. */
constexpr double kRedeskewVoxels = 0.5;

/** How far deskewing by `b` instead of `a` moves the scan's farthest point, to first order:
 *  a point at sweep time t moves by motion^(t - 1/2), so by half the sweeps' difference
 *  at the sweep's ends. */
double
skewChange(const Pose& a, const Pose& b, const Cloud& points)
{
  float reach = 0.0f;
  for (const auto& p : points)
    reach = std::max(reach, p.getVector3fMap().norm());
  const Pose d = a.inverse() * b;
  const double angle = Eigen::AngleAxisd(Eigen::Matrix3d(d.topLeftCorner<3, 3>())).angle();
  return 0.5 * (d.topRightCorner<3, 1>().norm() + angle * reach);
}

/** The reduced points' k-d tree (scanner frame): the scan's one tree, for its normals,
 *  the next scan's match to it and pLUM (ParallelLUM::setSearchTree: the tree pLUM would
 *  build, default bucket size, ids the point indices). */
std::shared_ptr<const KdTreeIndex>
scanTree(const Cloud& reduced, unsigned num_threads)
{
  auto tree = std::make_shared<KdTreeIndex>();
  tree->build(reduced.empty() ? nullptr : reduced.front().data,
              reduced.size(),
              sizeof(PointT) / sizeof(float),
              nullptr,
              num_threads);
  return tree;
}

/** The reduced points' normals (scanner frame): PCA of each one's 10 nearest reduced
 *  points, zero where the neighbourhood is degenerate. Reduced, not raw, neighbours: on a
 *  spinning LiDAR the nearest raw points lie along one ring, a nearly linear neighbourhood
 *  whose normal is poorly determined (docs/design.md, "Normals once per scan"). */
std::vector<Eigen::Vector3f>
reducedNormals(const KdTreeIndex& tree, std::size_t num_points, unsigned num_threads)
{
  std::vector<Eigen::Vector3f> normals(num_points, Eigen::Vector3f::Zero());
  if (tree.empty())
    return normals;
  // pLUM's estimator (the normals go to pLUM too), by tree position: back to point order.
  const std::vector<Eigen::Vector3f> by_position = estimateUnitNormals(tree, 10, num_threads);
  for (std::uint32_t pos = 0; pos < tree.size(); ++pos)
    normals[tree.id(pos)] = by_position[pos];
  return normals;
}

/** Builds the reduced scan's one tree and its normals, unless built: by the pose search,
 *  where it runs, else when the scan is kept, so that a scan deskewed again after its
 *  match is described once. */
void
describe(ReducedScan& scan, unsigned num_threads)
{
  if (scan.tree)
    return;
  scan.tree = scanTree(*scan.reduced, num_threads);
  scan.normals = reducedNormals(*scan.tree, scan.reduced->size(), num_threads);
}

/** The reduced points with their normals, NaN where none (pICP then skips a pair
 *  there), in the scanner frame: the points the scan's tree holds. */
MapCloud::Ptr
scannerFrameCloud(const Cloud& reduced, const std::vector<Eigen::Vector3f>& normals)
{
  MapCloud::Ptr out(new MapCloud);
  out->resize(reduced.size());
  const Eigen::Vector3f none =
      Eigen::Vector3f::Constant(std::numeric_limits<float>::quiet_NaN());
  for (std::size_t i = 0; i < reduced.size(); ++i) {
    MapPoint& p = (*out)[i];
    p.getVector3fMap() = reduced[i].getVector3fMap();
    p.getNormalVector3fMap() = normals[i] == Eigen::Vector3f::Zero() ? none : normals[i];
    p.curvature = 0.0f;
  }
  return out;
}

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

/** The reduced points that have a normal, with it: what goes into the local map. */
MapCloud::Ptr
withNormals(const Cloud& reduced, const std::vector<Eigen::Vector3f>& normals)
{
  MapCloud::Ptr out(new MapCloud);
  out->reserve(reduced.size());
  for (std::size_t i = 0; i < reduced.size(); ++i) {
    if (normals[i] == Eigen::Vector3f::Zero())
      continue;
    MapPoint p;
    p.getVector3fMap() = reduced[i].getVector3fMap();
    p.getNormalVector3fMap() = normals[i];
    p.curvature = 0.0f;
    out->push_back(p);
  }
  return out;
}

/** A match's gate and, with the adaptive threshold, its Geman-McClure kernel (scale
 *  sigma / 3 = gate / 9, KISS-ICP) and motion prior of the given spread (translation,
 *  rotation). */
void
configure(Icp& icp,
          double gate,
          bool adaptive,
          const Pose& prediction,
          const std::optional<std::pair<double, double>>& prior_spread)
{
  icp.setMaxCorrespondenceDistance(gate);
  icp.clearMotionPrior(); // a match without a prior must not keep the last one's
  if (!adaptive)
    return;
  const double scale = gate / 9.0;
  icp.setRobustKernel({registration::RobustKernel::Type::kGemanMcClure, scale});
  if (prior_spread) {
    const auto [sigma_t, sigma_r] = *prior_spread;
    icp.setMotionPrior(prediction,
                       (scale / sigma_t) * (scale / sigma_t),
                       (scale / sigma_r) * (scale / sigma_r));
  }
}

/** pICP from `guess` within `gate` (configure()), then refined from there within
 *  `final_gate` where that is narrower (coarse to fine; docs/design.md, "Coarse to
 *  fine"; 0: not refined). None if the wide match did not converge; its result if the
 *  refinement does not. `icp` is left with the returned match's pairs and Hessian. */
std::optional<Pose>
align(Icp& icp,
      const Pose& guess,
      double gate,
      double final_gate,
      bool adaptive,
      const Pose& prediction,
      const std::optional<std::pair<double, double>>& prior_spread)
{
  configure(icp, gate, adaptive, prediction, prior_spread);
  Cloud aligned;
  icp.alignDouble(aligned, guess);
  if (!icp.hasConverged())
    return std::nullopt;
  const Pose matched(icp.getFinalTransformationDouble());
  if (!(final_gate > 0.0))
    return matched;
  // The kernel's scale (gate / 9) stays at or above the residual spread the wide gate
  // measured, so sparse or noisy scans keep their inliers' weight.
  if (icp.getFinalWeight() > 0.0)
    final_gate =
        std::max(final_gate, 9.0 * std::sqrt(icp.getFinalError() / icp.getFinalWeight()));
  if (!(final_gate < gate))
    return matched;
  configure(icp, final_gate, adaptive, prediction, prior_spread);
  icp.alignDouble(aligned, matched);
  if (icp.hasConverged())
    return Pose(icp.getFinalTransformationDouble());
  // The wide match again, from its own result (it stays there), so that the statistics
  // read from `icp` (fitness, Hessian) are the returned pose's, not the failed refinement's.
  configure(icp, gate, adaptive, prediction, prior_spread);
  icp.alignDouble(aligned, matched);
  return icp.hasConverged() ? Pose(icp.getFinalTransformationDouble()) : matched;
}

/** The effective number of scans behind a map match (FrontEndResult::map_scans): each
 *  source point at `pose` counts for the scan of its nearest map point within `gate`. */
double
effectiveScans(const Cloud& source,
               const Pose& pose,
               const KdTreeIndex& map_index,
               const std::vector<std::uint32_t>& map_scans,
               double gate,
               unsigned num_threads)
{
  const Eigen::Matrix4f t = pose.cast<float>();
  std::vector<float> queries;
  queries.reserve(3 * source.size());
  for (const auto& p : source) {
    const Eigen::Vector3f q =
        t.topLeftCorner<3, 3>() * p.getVector3fMap() + t.topRightCorner<3, 1>();
    queries.insert(queries.end(), {q.x(), q.y(), q.z()});
  }
  const std::size_t n = source.size();
  std::vector<std::uint32_t> pos(n);
  std::vector<float> sqr(n);
  map_index.nearestBatch(queries.data(),
                         n,
                         3,
                         static_cast<float>(gate * gate),
                         pos.data(),
                         sqr.data(),
                         num_threads);
  std::vector<std::uint32_t> hits;
  hits.reserve(n);
  for (const std::uint32_t p : pos)
    if (p != KdTreeIndex::kInvalid && map_index.id(p) < map_scans.size())
      hits.push_back(map_scans[map_index.id(p)]);
  if (hits.empty())
    return 1.0;
  std::sort(hits.begin(), hits.end());
  double sum_sqr = 0.0; // the counts' squares; their sum is hits.size()
  for (std::size_t i = 0; i < hits.size();) {
    std::size_t j = i;
    while (j < hits.size() && hits[j] == hits[i])
      ++j;
    sum_sqr += static_cast<double>(j - i) * static_cast<double>(j - i);
    i = j;
  }
  const double count = static_cast<double>(hits.size());
  return count * count / sum_sqr;
}

/** pICP's body-frame Hessian (rotation first) over the residual variance, in the pose
 *  graph's order (translation first). */
Information
information(const Eigen::Matrix<double, 6, 6>& hessian, double error, double weight)
{
  if (!(weight > 6.0) || !hessian.allFinite())
    return Information::Zero();
  const double variance = std::max(error / weight, 1e-12);
  Information out;
  out << hessian.bottomRightCorner<3, 3>(), hessian.bottomLeftCorner<3, 3>(),
      hessian.topRightCorner<3, 3>(), hessian.topLeftCorner<3, 3>();
  return out / variance;
}

} // namespace

FrontEnd::FrontEnd(const FrontEndParameters& params)
    : params_(params)
    , icp_(new Registration)
    , map_(params.map_voxel_size,
           params.map_distance,
           params.map_points_per_voxel,
           LocalMap::kRefreshFraction,
           params.num_threads)
    , previous_tree_(new search::KdTree<MapPoint>)
{
  for (Icp* icp : {&icp_->icp, &icp_->to_previous}) {
    icp->setNumberOfThreads(params.num_threads);
    icp->setMaxCorrespondenceDistance(params.max_correspondence_distance);
    icp->setMaximumIterations(params.max_iterations);
    icp->setTransformationEpsilon(params.transformation_epsilon);
    icp->setUsePointToPlane(params.point_to_plane);
    icp->setUseTargetNormalFields(!params.normals_from_map);
  }
  if (params.adaptive_threshold) // KISS-ICP: min motion 0.1 m at 1 m voxels, max range
    icp_->threshold.reset(
        new registration::AdaptiveThreshold(params.max_correspondence_distance,
                                            kMinMotionVoxels * params.map_voxel_size,
                                            params.map_distance));
}

double
FrontEnd::gate() const
{
  return icp_->threshold ? std::min(params_.max_correspondence_distance,
                                    icp_->threshold->correspondenceDistance())
                         : params_.max_correspondence_distance;
}

std::pair<double, double>
FrontEnd::priorSpread() const
{
  const registration::AdaptiveThreshold& th = *icp_->threshold;
  if (th.numDeviations() < kPriorSpreadSamples) { // the gate's sigma, rotation at max range
    const double sigma = gate() / 3.0;
    return {sigma, sigma / th.maxRange()};
  }
  // Translation and rotation each from their own deviations: the combined sigma is
  // dominated by rotation times max range (docs/design.md, "The motion prior's spread").
  // Below min motion a deviation is not measured, so neither is a spread.
  return {std::max(th.translationSigma(), th.minMotion()),
          std::max(th.rotationSigma(), th.minMotion() / th.maxRange())};
}

std::optional<std::pair<double, double>>
FrontEnd::priorSpreadIfUsed() const
{
  if (!icp_->threshold || !params_.motion_prior)
    return std::nullopt;
  return priorSpread();
}

const Pose&
FrontEnd::priorMean(const FrontEndResult& r, const Pose& guess)
{
  // Where the pose search placed the scan, the prediction is what the search found wrong
  // (docs/design.md, "Where the site repeats").
  return std::isfinite(r.start_heading) ? guess : r.prediction;
}

FrontEnd::~FrontEnd() = default;

FrontEndResult
FrontEnd::track(const Cloud& scan,
                const std::optional<Pose>& odometry,
                std::optional<double> stamp,
                const std::vector<float>& sweep_times)
{
  if (!sweep_times.empty())
    requireOnePerPoint(scan, sweep_times.size(), "FrontEnd::track");
  FrontEndResult r;
  const bool first = scans_++ == 0;
  const double gap = stamp && last_stamp_ ? *stamp - *last_stamp_ : 0.0;
  const Motion motion = predictMotion(odometry, gap);
  r.prediction = first ? (odometry ? *odometry : Pose::Identity()) : Pose(pose_ * motion.step);

  // The first scan comes before any motion is known: it is deskewed again once the first
  // step is, here from the odometry, else after the match (docs/design.md, "The first scan").
  if (params_.deskew && first) {
    first_scan_.reset(new Cloud(scan));
    first_scan_times_ = sweep_times;
  }
  else if (first_scan_ && odometry)
    r.first_scan = deskewFirstAgain(motion.sweep);
  ReducedScan reduced = reduce(scan, sweep_times, motion.sweep);
  auto source = sourceOf(reduced);

  r.pose = r.prediction;
  const bool to_map = params_.target == MatchTarget::kLocalMap;
  const bool has_target = to_map ? !map_.empty() : hasPrevious();
  if (!first && has_target && !source->empty()) {
    r.gate = gate();
    Icp& icp = to_map ? icp_->icp : icp_->to_previous;
    std::optional<Pose> matched;
    Pose prior_mean = r.prediction;
    if (to_map) {
      icp.setInputSource(source);
      if (map_.cloud() != target_) // the tree is rebuilt only for a new map
        icp.setInputTarget(target_ = map_.cloud());
      const Pose guess = initialGuess(source, reduced, r.prediction, odometry.has_value(), r);
      prior_mean = priorMean(r, guess);
      matched = matchFrom(source, guess, prior_mean);
    }
    else { // the best guess refined (without odometry; with it, the prediction)
      std::optional<Pose> own, better;
      if (!odometry && (params_.speed_hypotheses || params_.pose_search)) {
        own = alignToPrevious(source, r.prediction, false);
        better = betterGuess(source, reduced, r.prediction, own, r);
      }
      if (better)
        prior_mean = priorMean(r, *better);
      // From the prediction's wide match, made already, the same wide stage stops at once.
      matched = matchFrom(source, better ? *better : own.value_or(r.prediction), prior_mean);
    }
    // Deskewed by the predicted step, a scan taken while the motion changed (a turn
    // begun or ended) is skewed by the change: deskewed again by the matched step and
    // matched again from where it was matched.
    if (const auto sweep =
            params_.deskew && matched && !first_scan_
                ? sweepToDeskewAgain(*matched, motion.sweep, gap, *reduced.reduced)
                : std::nullopt) {
      ReducedScan again = reduce(scan, sweep_times, *sweep);
      const auto again_source = sourceOf(again);
      if (const auto rematched = matchFrom(again_source, *matched, prior_mean)) {
        matched = rematched;
        reduced = std::move(again);
        source = again_source;
        r.deskewed_again = true;
      }
      else // the first match again, from itself: its scan, pairs and Hessian are kept
        matched = matchFrom(source, *matched, prior_mean);
    }
    r.converged = matched.has_value();
    if (matched) {
      // Constant velocity multiplies each pose by a step taken from the two before it,
      // which compounds rounding (mulran, 332 keyframes: |RᵀR - I| grew to 1e-9, faster
      // than linearly), and odometry read from text carries its digits' error.
      r.pose = orthonormalized(*matched);
      r.fitness = icp.getFitnessScore(r.gate * r.gate); // squared, as PCL's max_range
      r.information =
          information(icp.getFinalHessian(), icp.getFinalError(), icp.getFinalWeight());
      r.information_pairs = icp.getFinalWeight();
      // The map's tree, built over map_.cloud(), whose points' scans map_.scans() holds.
      const auto* tree =
          dynamic_cast<const search::KdTree<MapPoint>*>(icp.getSearchMethodTarget().get());
      if (to_map && tree && icp.getInputTarget() == map_.cloud())
        r.map_scans = effectiveScans(*source,
                                     r.pose,
                                     tree->index(),
                                     map_.scans(),
                                     params_.final_correspondence_distance > 0.0
                                         ? params_.final_correspondence_distance
                                         : r.gate,
                                     params_.num_threads);
      if (icp_->threshold) // how far the match moved the scan from the prior
        icp_->threshold->updateModelDeviation(r.prediction.inverse() * r.pose);
    }
  }
  r.source_points = source->size();
  velocity_ = first ? Pose::Identity() : Pose(pose_.inverse() * r.pose);
  if (velocity_.topRightCorner<3, 1>().norm() >= params_.voxel_size)
    heading_ = velocity_.topRightCorner<3, 1>().normalized();
  velocity_span_ = gap;
  last_stamp_ = stamp;
  if (first_scan_ && !first) { // both scans were matched as they came, neither deskewed
    const Pose sweep = sweepMotion(velocity_, gap, params_.sweep_period);
    r.first_scan = deskewFirstAgain(sweep);
    reduced = reduce(scan, sweep_times, sweep);
  }
  pose_ = r.pose;

  r.scan = keep(std::move(reduced), static_cast<std::uint32_t>(scans_));
  return r;
}

ReducedScan
FrontEnd::deskewFirstAgain(const Pose& sweep)
{
  map_.clear();     // of the first scan alone, at pose_
  ReducedScan out = // the first scan, kept again while the second is tracked
      keep(reduce(*first_scan_, first_scan_times_, sweep),
           static_cast<std::uint32_t>(scans_ - 1));
  first_scan_.reset();
  first_scan_times_.clear();
  return out;
}

ReducedScan
FrontEnd::reduce(const Cloud& scan,
                 const std::vector<float>& sweep_times,
                 const Pose& sweep) const
{
  const Cloud::Ptr frame =
      params_.deskew
          ? deskewSweep(scan, sweep_times, sweep, params_.sweep_clockwise, params_.num_threads)
          : Cloud::Ptr(new Cloud(scan));
  ReducedScan reduced;
  reduced.reduced = filters::voxelCentroid(*frame, params_.voxel_size, params_.num_threads);
  return reduced;
}

Cloud::Ptr
FrontEnd::sourceOf(const ReducedScan& scan) const
{
  return filters::voxelNearestToCentroid(
      *scan.reduced, params_.source_voxel_size, params_.num_threads);
}

ReducedScan
FrontEnd::keep(ReducedScan kept, std::uint32_t id)
{
  // Into the map at pose_, and kept in the scanner frame for the next scan's match to it.
  describe(kept, params_.num_threads);
  const Cloud::Ptr& reduced = kept.reduced;
  const bool to_map = params_.target == MatchTarget::kLocalMap;
  if (to_map) {
    const MapCloud::Ptr world = withNormals(*reduced, kept.normals);
    pcl::transformPointCloudWithNormals(*world, *world, pose_);
    map_.update(*world, pose_.topRightCorner<3, 1>(), id);
  }
  if (to_map && !params_.guess_from_previous_scan)
    return kept; // the previous scan is not matched
  previous_ = scannerFrameCloud(*reduced, kept.normals);
  previous_tree_->setInputCloudAndIndex(previous_, kept.tree);
  previous_index_ = kept.tree;
  previous_points_ = reduced;
  return kept;
}

FrontEnd::Motion
FrontEnd::predictMotion(const std::optional<Pose>& odometry, double gap)
{
  Motion m;
  if (odometry && last_odometry_) { // the odometry step (paper Sec. II)
    m.step = last_odometry_->inverse() * *odometry;
    // The sweep is at the step's end: deskewed at the velocity there, not the step's mean.
    m.sweep = sweepMotion(odometry_step_
                              ? extrapolateMotion(m.step, gap, *odometry_step_, odometry_span_)
                              : m.step,
                          gap,
                          params_.sweep_period);
    odometry_step_ = m.step;
    odometry_span_ = gap;
  }
  else { // constant velocity (KISS-ICP Sec. III-B), per second where there are stamps
    m.step =
        gap > 0.0 && velocity_span_ > 0.0
            ? interpolateMotion(
                  velocity_,
                  std::clamp(gap / velocity_span_, 1.0 / kMaxVelocityScale, kMaxVelocityScale))
            : velocity_;
    m.sweep = sweepMotion(m.step, gap, params_.sweep_period);
  }
  if (odometry)
    last_odometry_ = odometry;
  return m;
}

bool
FrontEnd::hasPrevious() const
{
  return previous_ && !previous_->empty();
}

std::optional<Pose>
FrontEnd::alignToPrevious(const Cloud::ConstPtr& source,
                          const Pose& prediction,
                          bool refined,
                          const Pose* prior_mean)
{
  // In the previous scan's frame (its pose is still pose_), on the tree built with it.
  const Pose to_previous = pose_.inverse();
  Icp& icp = icp_->to_previous;
  icp.setInputSource(source);
  icp.setSearchMethodTarget(previous_tree_, true);
  icp.setInputTarget(previous_);
  const Pose guess = to_previous * prediction;
  const auto matched = align(icp,
                             guess,
                             gate(),
                             refined ? params_.final_correspondence_distance : 0.0,
                             icp_->threshold != nullptr,
                             prior_mean ? Pose(to_previous * *prior_mean) : guess,
                             priorSpreadIfUsed());
  if (!matched)
    return std::nullopt;
  return Pose(pose_ * *matched);
}

std::optional<Pose>
FrontEnd::matchFrom(const Cloud::ConstPtr& source, const Pose& start, const Pose& prior_mean)
{
  if (params_.target != MatchTarget::kLocalMap)
    return alignToPrevious(source, start, true, &prior_mean);
  Icp& icp = icp_->icp;
  if (icp.getInputSource() != source)
    icp.setInputSource(source);
  return align(icp,
               start,
               gate(),
               params_.final_correspondence_distance,
               icp_->threshold != nullptr,
               prior_mean,
               priorSpreadIfUsed());
}

std::optional<Pose>
FrontEnd::sweepToDeskewAgain(const Pose& matched,
                             const Pose& predicted,
                             double gap,
                             const Cloud& reduced) const
{
  const Pose step(pose_.inverse() * matched);
  const Pose sweep =
      sweepMotion(scans_ > 2 ? extrapolateMotion(step, gap, velocity_, velocity_span_) : step,
                  gap,
                  params_.sweep_period);
  if (!(skewChange(predicted, sweep, reduced) > kRedeskewVoxels * params_.voxel_size))
    return std::nullopt;
  return sweep;
}

FrontEnd::Hypotheses
FrontEnd::hypotheses(const Cloud& source, const Pose& prediction) const
{
  Hypotheses h;
  if (!params_.speed_hypotheses || !hasPrevious() || source.empty())
    return h;
  const double same = sameSolution();
  const Pose step = pose_.inverse() * prediction;
  // Speed: along the predicted step, or the way the scanner last moved (in its frame).
  const Eigen::Vector3d t = step.topRightCorner<3, 1>();
  h.travel = t.norm() >= params_.voxel_size ? t.normalized() : heading_;
  h.speed = t.dot(h.travel);
  const double sigma = gate() / 3.0;
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
FrontEnd::sameSolution() const
{
  // Starts or matches closer than the refinement gate lie in one basin.
  return std::max(params_.final_correspondence_distance, params_.voxel_size);
}

bool
FrontEnd::atPreviousScan(const Pose& local) const
{
  return local.topRightCorner<3, 1>().norm() <= sameSolution();
}

bool
FrontEnd::isRival(const Pose& leader, const Pose& other, double range) const
{
  // A match where the best so far ended is the same solution; one that ends where the
  // previous scan was taken shares its sampling pattern, so its fitness and overlap are
  // no measure against a match that moves (docs/design.md, "Standing still").
  return registration::motionDisplacement(leader.inverse() * other, range) > sameSolution() &&
         !(atPreviousScan(other) && !atPreviousScan(leader));
}

std::optional<Pose>
FrontEnd::bestHypothesis(const Cloud::ConstPtr& source,
                         const Pose& prediction,
                         const std::optional<Pose>& own,
                         const Hypotheses& h,
                         FrontEndResult& r)
{
  const double gate = this->gate(), same = sameSolution();
  // Fitness over the pairs within sqrt(gate): PCL's max_range is a squared distance, and
  // the gate (metres) goes in as it. That radius depends on the units (1-2.9 m for gates
  // of 1-8.25 m); the unit-free radii and fits tried instead each lost the drive or a
  // corridor set (docs/design.md, "Speed hypotheses").
  double best =
      own ? icp_->to_previous.getFitnessScore(gate) : std::numeric_limits<double>::infinity();
  std::optional<Pose> winner;
  const Pose to_previous = pose_.inverse(); // rivals are compared in its frame
  // A better fit is no measure where it contradicts the previous scan more: the stop
  // fits better by the shared sampling pattern, yet puts the far walls of the corridor
  // into its open space (docs/design.md, "Standing still").
  std::unique_ptr<FreeSpace> seen;
  const auto contradictsMore = [&](const Pose& other, const Pose& leader) {
    if (!seen)
      seen.reset(new FreeSpace(*previous_points_, params_.up));
    const double a = seen->conflicts(*source, other, same),
                 b = seen->conflicts(*source, leader, same);
    return a - b > kConflictSignificance * std::sqrt((a + b) / source->size());
  };
  // The prior stays at the prediction: what the motion model believes, not the start.
  const auto tryStart = [&](const Pose& start, double offset, double turn) {
    const std::optional<Pose> other = alignToPrevious(source, start, false, &prediction);
    if (!other)
      return;
    const double fitness = icp_->to_previous.getFitnessScore(gate);
    const std::optional<Pose>& leader = winner ? winner : own;
    if (leader && !isRival(to_previous * *leader, to_previous * *other, h.range))
      return;
    if (fitness < best &&
        !(leader && contradictsMore(to_previous * *other, to_previous * *leader))) {
      best = fitness;
      winner = other;
      r.start_offset = offset;
      r.start_turn = turn;
    }
  };
  for (const double k : {-2.0, -1.0, 1.0, 2.0})
    // Speed, not direction: a start behind the previous scan's position would reverse the
    // travel, and along a street it ends in a false fit behind (docs/design.md, "Standing
    // still").
    if (h.sigma > 0.0 && std::abs(k) * h.sigma > same && h.speed + k * h.sigma >= -same) {
      Pose start = prediction;
      start.topRightCorner<3, 1>() += pose_.topLeftCorner<3, 3>() * (k * h.sigma * h.travel);
      tryStart(start, k * h.sigma, 0.0);
    }
  if (h.turn.angle() > 0.0) {
    Pose step = pose_.inverse() * prediction;
    for (const double k : {-1.0, 1.0}) { // the predicted turn stopped, doubled
      step.topLeftCorner<3, 3>() =
          Eigen::AngleAxisd((1.0 + k) * h.turn.angle(), h.turn.axis()).toRotationMatrix();
      tryStart(pose_ * step, 0.0, k);
    }
  }
  return winner;
}

std::optional<Pose>
FrontEnd::searchPose(const Cloud::ConstPtr& source,
                     ReducedScan& scan,
                     const std::optional<Pose>& own,
                     double range,
                     FrontEndResult& r)
{
  if (!params_.pose_search || !hasPrevious() || source->empty())
    return std::nullopt;
  // In the previous scan's frame: how much of it the prediction's match sees.
  const double same = sameSolution();
  const std::optional<Pose> own_local =
      own ? std::optional<Pose>(pose_.inverse() * *own) : std::nullopt;
  const double own_overlap =
      own_local ? overlap(*source, *own_local, *previous_index_, same) : 0.0;
  // Searched only where the match looks wrong: the first, one that sees far less of the
  // previous scan than the recent matches did, or one where a turn hypothesis won (the
  // prediction missed the turn by its own size: a turn nothing predicted).
  if (!overlaps_.empty() && r.start_turn == 0.0 &&
      own_overlap >= kSearchOverlapRatio * median(overlaps_)) {
    keepOverlap(own_overlap);
    return std::nullopt;
  }
  r.pose_searched = true;
  CorrelativeSearchParameters search;
  search.cell = 2.0 * params_.voxel_size;
  search.num_threads = params_.num_threads;
  Icp& icp = icp_->to_previous;
  icp.setSearchMethodTarget(previous_tree_, true);
  icp.setInputTarget(previous_);
  icp.setInputSource(source);
  if (!(range > 0.0))
    range = medianRange(*source);
  // Searched and judged on both scans' upright points where they have them. A candidate
  // must overlap the previous scan clearly more than `own`, and agree with it more:
  // overlap less conflicts (points in the space it saw through); of those, the one that
  // agrees most wins (docs/design.md, "Where the site repeats").
  describe(scan, params_.num_threads);
  const Cloud& reduced = *scan.reduced;
  const Cloud::Ptr walls = upright(*scannerFrameCloud(reduced, scan.normals), params_.up);
  const Cloud::Ptr previous_walls = upright(*previous_, params_.up);
  const bool on_walls =
      walls->size() >= kMinUprightPoints && previous_walls->size() >= kMinUprightPoints;
  const Cloud::ConstPtr judged =
      on_walls ? Cloud::ConstPtr(everyKth(*walls, source->size())) : source;
  const FreeSpace seen(*previous_points_, params_.up);
  const auto judge = [&](const Pose& local) {
    return std::make_pair(overlap(*judged, local, *previous_index_, same),
                          seen.conflicts(*judged, local, same));
  };
  const auto [own_agrees, own_conflicts] =
      own_local ? judge(*own_local) : std::make_pair(0.0, 0.0);
  const double own_net = own_agrees - own_conflicts;
  double best = -std::numeric_limits<double>::infinity();
  std::optional<Pose> winner;
  const Cloud& searched = on_walls ? *walls : reduced;
  for (const Pose& start : correlativeSearch(
           searched, on_walls ? *previous_walls : *previous_points_, params_.up, search)) {
    // From a candidate good to a cell: a gate of two cells, no prior (none predicted it).
    const auto m = align(icp,
                         start,
                         std::min(params_.max_correspondence_distance, 2.0 * search.cell),
                         params_.final_correspondence_distance,
                         icp_->threshold != nullptr,
                         start,
                         std::nullopt);
    if (!m || (own_local && !isRival(*own_local, *m, range)))
      continue;
    const auto [agrees, conflicts] = judge(*m);
    if (agrees > kSearchMargin * own_agrees && agrees - conflicts > own_net &&
        agrees - conflicts > best) {
      best = agrees - conflicts;
      winner = *m;
      const Eigen::AngleAxisd turn(Eigen::Matrix3d(start.topLeftCorner<3, 3>()));
      r.start_heading = turn.axis().dot(params_.up) < 0.0 ? -turn.angle() : turn.angle();
    }
  }
  keepOverlap(winner ? overlap(*source, *winner, *previous_index_, same) : own_overlap);
  if (winner)
    winner = pose_ * *winner;
  return winner;
}

void
FrontEnd::keepOverlap(double o)
{
  overlaps_.push_back(o);
  if (overlaps_.size() > kSearchOverlapHistory)
    overlaps_.erase(overlaps_.begin());
}

Pose
FrontEnd::initialGuess(const Cloud::ConstPtr& source,
                       ReducedScan& scan,
                       const Pose& prediction,
                       bool odometry,
                       FrontEndResult& r)
{
  if (!params_.guess_from_previous_scan || odometry || !hasPrevious())
    return prediction;
  const std::optional<Pose> own = alignToPrevious(source, prediction, false);
  return betterGuess(source, scan, prediction, own, r).value_or(own.value_or(prediction));
}

std::optional<Pose>
FrontEnd::betterGuess(const Cloud::ConstPtr& source,
                      ReducedScan& scan,
                      const Pose& prediction,
                      const std::optional<Pose>& own,
                      FrontEndResult& r)
{
  // A hypothesis' match where one fits better, the search's where even that looks wrong:
  // the search is the last resort, the costliest and the least local.
  std::optional<Pose> better;
  const Hypotheses h = hypotheses(*source, prediction);
  if (h.any())
    better = bestHypothesis(source, prediction, own, h, r);
  if (auto found = searchPose(source, scan, better ? better : own, h.range, r))
    better = found;
  return better;
}

void
FrontEnd::applyCorrection(const Pose& correction)
{
  // The previous scan, kept in its own frame, moves with it.
  pose_ = orthonormalized(correction * pose_);
  map_.transform(correction);
}

void
FrontEnd::setLastPose(const Pose& pose)
{
  applyCorrection(pose * pose_.inverse());
}

} // namespace slam
} // namespace pcl_parallel
