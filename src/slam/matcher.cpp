/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/registration/adaptive_threshold.h>
#include <pcl_parallel/registration/icp.h>
#include <pcl_parallel/search/kdtree.h>
#include <pcl_parallel/slam/matcher.h>
#include <pcl_parallel/slam/reducer.h>

#include <pcl/common/transforms.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace pcl_parallel {
namespace slam {

namespace {
using Icp = ParallelIterativeClosestPoint<PointT, MapPoint, float>;

/** KISS-ICP's min motion for the adaptive threshold, in map voxels (0.1 m at 1 m). */
constexpr double kMinMotionVoxels = 0.1;
/** Deviations kept before the prior's spread is taken from them: sigma from n samples is
 *  known to about 1/sqrt(2n), 16 % at 20. */
constexpr std::size_t kPriorSpreadSamples = 20;
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

/** The effective number of scans behind a map match (ScanReport::map_scans): each
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

/** r's information and its pairs from `icp`'s last match. */
void
takeInformation(ScanRecord& r, Icp& icp)
{
  r.information =
      matchInformation(icp.getFinalHessian(), icp.getFinalError(), icp.getFinalWeight());
  r.information_pairs = icp.getFinalWeight();
}

} // namespace

Information
matchInformation(const Eigen::Matrix<double, 6, 6>& hessian,
                 double error,
                 double weight,
                 double min_weight)
{
  if (!(weight > min_weight) || !hessian.allFinite())
    return Information::Zero();
  const double variance = std::max(error / weight, 1e-12);
  Information out;
  out << hessian.bottomRightCorner<3, 3>(), hessian.bottomLeftCorner<3, 3>(),
      hessian.topRightCorner<3, 3>(), hessian.topLeftCorner<3, 3>();
  return out / variance;
}

struct Matcher::Registration {
  // The target's normals come with it (setUseTargetNormalFields): estimated once per scan.
  Icp icp;         ///< against the local map
  Icp to_previous; ///< against the previous scan; its own object keeps icp's map tree
  std::unique_ptr<registration::AdaptiveThreshold> threshold;
};

Matcher::Matcher(const Parameters& resolved)
    : params_(resolved.matcher)
    , keep_previous_(params_.target == MatchTarget::kPreviousScan ||
                     resolved.guess.guess_from_previous_scan)
    , planar_(resolved.planar)
    , num_threads_(resolved.num_threads)
    , icp_(new Registration)
    , map_(params_.map_voxel_size,
           params_.map_distance,
           params_.map_points_per_voxel,
           NormalsFromMap{params_.normals_from_map ? Icp::kDefaultNormalK : 0u, planar_},
           num_threads_)
    , previous_tree_(new search::KdTree<MapPoint>)
    , map_tree_(new search::KdTree<MapPoint>)
{
  if (!isResolved(resolved))
    throw std::invalid_argument("Matcher: the parameters' automatic lengths are not resolved");
  const MatcherParameters& params = params_;
  for (Icp* icp : {&icp_->icp, &icp_->to_previous}) {
    icp->setNumberOfThreads(num_threads_);
    icp->setMaxCorrespondenceDistance(params.max_correspondence_distance);
    icp->setMaximumIterations(params.max_iterations);
    icp->setTransformationEpsilon(params.transformation_epsilon);
    icp->setUsePointToPlane(params.point_to_plane);
    icp->setPlanar(resolved.planar);
  }
  // The map's points carry normals, their own or the map's (LocalMap::NormalsFromMap); the
  // previous scan's own are too few where the map's are wanted, so ICP estimates those.
  icp_->to_previous.setUseTargetNormalFields(!params.normals_from_map);
  if (params.adaptive_threshold) // KISS-ICP: min motion 0.1 m at 1 m voxels, max range
    icp_->threshold.reset(
        new registration::AdaptiveThreshold(params.max_correspondence_distance,
                                            kMinMotionVoxels * params.map_voxel_size,
                                            params.map_distance));
}

Matcher::~Matcher() = default;

double
Matcher::gate() const
{
  return icp_->threshold ? std::min(params_.max_correspondence_distance,
                                    icp_->threshold->correspondenceDistance())
                         : params_.max_correspondence_distance;
}

double
Matcher::finalGate() const
{
  const double final_gate = params_.final_correspondence_distance;
  return final_gate > 0.0 ? std::min(final_gate, gate()) : gate();
}

std::optional<std::pair<double, double>>
Matcher::priorSpread() const
{
  if (!icp_->threshold || !params_.motion_prior)
    return std::nullopt;
  const registration::AdaptiveThreshold& th = *icp_->threshold;
  constexpr double kFree = std::numeric_limits<double>::infinity();
  if (th.numDeviations() < kPriorSpreadSamples) { // the gate's sigma, rotation at max range
    const double sigma = gate() / 3.0;
    return std::make_pair(sigma, planar_ ? kFree : sigma / th.maxRange());
  }
  // Translation and rotation each from their own deviations: the combined sigma is
  // dominated by rotation times max range (docs/design.md, "The motion prior's spread").
  // Below min motion a deviation is not measured, so neither is a spread.
  return std::make_pair(std::max(th.translationSigma(), th.minMotion()),
                        planar_ ? kFree
                                : std::max(th.rotationSigma(), th.minMotion() / th.maxRange()));
}

bool
Matcher::hasTarget() const
{
  return params_.target == MatchTarget::kLocalMap ? !map_.empty() : !previous_.empty();
}

void
Matcher::usePrevious(const Cloud::ConstPtr& source)
{
  Icp& icp = icp_->to_previous;
  icp.setInputSource(source);
  icp.setSearchMethodTarget(previous_tree_, true); // the tree built with the scan
  icp.setInputTarget(previous_.cloud);
}

std::optional<Pose>
Matcher::alignTo(bool to_map,
                 const Cloud::ConstPtr& source,
                 const Pose& start,
                 const Pose& prior_mean,
                 const Pose& at,
                 double gate,
                 double final_gate)
{
  const bool adaptive = icp_->threshold != nullptr;
  if (to_map) {
    Icp& icp = icp_->icp;
    if (icp.getInputSource() != source)
      icp.setInputSource(source);
    if (map_.cloud() != target_) // the tree changes only with the map
      useMap();
    return align(icp, start, gate, final_gate, adaptive, prior_mean, priorSpread());
  }
  // In the previous scan's frame.
  const Pose to_previous = at.inverse();
  usePrevious(source);
  const auto matched = align(icp_->to_previous,
                             to_previous * start,
                             gate,
                             final_gate,
                             adaptive,
                             Pose(to_previous * prior_mean),
                             priorSpread());
  if (!matched)
    return std::nullopt;
  return Pose(at * *matched);
}

std::optional<Pose>
Matcher::alignToPrevious(const Cloud::ConstPtr& source,
                         const Pose& start,
                         bool refined,
                         const Pose* prior_mean,
                         const Pose& at)
{
  return alignTo(false,
                 source,
                 start,
                 prior_mean ? *prior_mean : start,
                 at,
                 gate(),
                 refined ? params_.final_correspondence_distance : 0.0);
}

std::optional<Pose>
Matcher::alignInPrevious(const Pose& start, double gate)
{
  return align(icp_->to_previous,
               start,
               gate,
               params_.final_correspondence_distance,
               icp_->threshold != nullptr,
               start,
               std::nullopt);
}

double
Matcher::previousFitness(double max_range) const
{
  return icp_->to_previous.getFitnessScore(max_range);
}

std::optional<Pose>
Matcher::match(const Cloud::ConstPtr& source,
               const Pose& start,
               const Pose& prior_mean,
               const Pose& at)
{
  return alignTo(params_.target == MatchTarget::kLocalMap,
                 source,
                 start,
                 prior_mean,
                 at,
                 gate(),
                 params_.final_correspondence_distance);
}

std::optional<Pose>
Matcher::refine(const Cloud::ConstPtr& source,
                const Pose& start,
                const Pose& prior_mean,
                const Pose& at)
{
  return alignTo(params_.target == MatchTarget::kLocalMap,
                 source,
                 start,
                 prior_mean,
                 at,
                 finalGate(),
                 0.0);
}

bool
Matcher::fitPath(SweepPath& path,
                 const Cloud& scan,
                 const std::vector<float>& times,
                 const SweepPathPrior& prior)
{
  // Against the local map's tree, built by the match before. One previous scan holds too
  // few pairs to fit a path (docs/design.md): scan-to-scan matching keeps its deskewing.
  const search::KdTree<MapPoint>* tree =
      params_.target == MatchTarget::kLocalMap ? mapTree() : nullptr;
  if (!tree)
    return false;
  SweepPath fitted = path;
  if (!fitSweepPath(fitted,
                    scan,
                    times,
                    *map_.cloud(),
                    tree->index(),
                    finalGate(),
                    prior,
                    params_.max_iterations,
                    num_threads_))
    return false;
  path = fitted;
  return true;
}

void
Matcher::measure(ScanRecord& r, const Cloud::ConstPtr& source)
{
  const bool to_map = params_.target == MatchTarget::kLocalMap;
  Icp& icp = to_map ? icp_->icp : icp_->to_previous;
  ScanReport& report = r.report;
  report.fitness = icp.getFitnessScore(report.gate * report.gate); // squared, as PCL's
  takeInformation(r, icp);
  // map_.scans() holds the scans of the points of the map's tree.
  if (const search::KdTree<MapPoint>* tree = to_map ? mapTree() : nullptr)
    report.map_scans = effectiveScans(*source,
                                      r.pose,
                                      tree->index(),
                                      map_.scans(),
                                      params_.final_correspondence_distance > 0.0
                                          ? params_.final_correspondence_distance
                                          : report.gate,
                                      num_threads_);
  if (icp_->threshold) // how far the match moved the scan from the prior
    icp_->threshold->updateModelDeviation(r.prediction.inverse() * r.pose);
}

void
Matcher::useMap()
{
  Icp& icp = icp_->icp;
  target_ = map_.cloud();
  map_tree_->setInputCloudAndIndex(target_, map_.index()); // ICP builds no tree of its own
  icp.setSearchMethodTarget(map_tree_, true);
  icp.setInputTarget(target_);
}

const search::KdTree<MapPoint>*
Matcher::mapTree() const
{
  return target_ && target_ == map_.cloud() ? map_tree_.get() : nullptr; // useMap's
}

void
Matcher::keep(const ReducedScan& scan, const Pose& pose, std::uint32_t id)
{
  // Into the map at `pose`, and kept in the scanner frame for the next scan's match to it.
  const bool to_map = params_.target == MatchTarget::kLocalMap;
  if (to_map) {
    const MapCloud::Ptr world = withNormals(scan);
    pcl::transformPointCloudWithNormals(*world, *world, pose);
    map_.update(*world, pose.topRightCorner<3, 1>(), id);
  }
  if (!keep_previous_)
    return; // the previous scan is not matched
  previous_.cloud = scannerFrameCloud(scan);
  previous_tree_->setInputCloudAndIndex(previous_.cloud, scan.tree);
  previous_.index = scan.tree;
  previous_.points = scan.reduced;
}

} // namespace slam
} // namespace pcl_parallel
