/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/filters/voxel_grid.h>
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/registration/adaptive_threshold.h>
#include <pcl_parallel/registration/icp.h>
#include <pcl_parallel/registration/lum.h>
#include <pcl_parallel/slam/correlative_search.h>
#include <pcl_parallel/slam/loop_closure.h>
#include <pcl_parallel/slam/overlap.h>
#include <pcl_parallel/slam/preprocess.h>

#include <pcl/common/transforms.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <queue>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>

namespace pcl_parallel {
namespace slam {

struct LoopCloser::Impl {
  ParallelLUM<PointT> lum;
  ParallelIterativeClosestPoint<PointT, PointT, double> icp;
  std::vector<std::shared_ptr<const KdTreeIndex>> trees; ///< pLUM's, per scan held here
  std::size_t points = 0;                                ///< of every scan
  std::size_t kept_points = 0;                           ///< of the scans held here
};

LoopCloser::LoopCloser(const Parameters& resolved)
    : params_(resolved.loops)
    , median_range_(resolved.median_range)
    , source_voxel_size_(resolved.reduction.source_voxel_size)
    , planar_(resolved.planar)
    , up_(resolved.guess.up)
    , num_threads_(resolved.num_threads)
    , impl_(new Impl)
{
  if (!isResolved(resolved))
    throw std::invalid_argument(
        "LoopCloser: the parameters' automatic lengths are not resolved");
  const LoopClosureParameters& params = params_;
  impl_->icp.setNumberOfThreads(num_threads_);
  impl_->icp.setMaxCorrespondenceDistance(params.icp_distance);
  impl_->icp.setMaximumIterations(params.icp_iterations);
  impl_->icp.setTransformationEpsilon(params.icp_epsilon);
  impl_->icp.setPlanar(resolved.planar);
  auto& lum = impl_->lum;
  lum.setPlanar(resolved.planar);
  lum.setNumberOfThreads(num_threads_);
  lum.setCorrespondenceDistanceSchedule(
      params.lum_distance, std::min(params.lum_distance, params.lum_final_distance), 0.7);
  lum.setPointToPlane(params.lum_point_to_plane);
  lum.setLinkIterations(params.lum_link_iterations);
  lum.setMaxIterations(params.lum_iterations);
  lum.setConvergenceThreshold(static_cast<float>(params.lum_epsilon));
}

LoopCloser::~LoopCloser() = default;

void
LoopCloser::setExchange(std::shared_ptr<ScanExchange> exchange)
{
  if (!scans_.empty())
    throw std::logic_error("LoopCloser::setExchange: set it before the first scan");
  exchange_ = std::move(exchange);
}

int
LoopCloser::owner(std::size_t i) const
{
  return exchange_ ? exchange_->owner(i) : 0;
}

bool
LoopCloser::owns(std::size_t i) const
{
  return !exchange_ || exchange_->owner(i) == exchange_->rank();
}

void
LoopCloser::addScan(const Cloud::ConstPtr& scan,
                    const Pose& pose,
                    std::vector<Eigen::Vector3f> normals,
                    const Information& information,
                    double information_pairs,
                    double information_scans,
                    std::size_t num_points,
                    std::shared_ptr<const KdTreeIndex> tree)
{
  const std::size_t j = scans_.size();
  const bool own = owns(j);
  if (own != static_cast<bool>(scan))
    throw std::invalid_argument("LoopCloser::addScan: scan " + std::to_string(j) +
                                (own ? " has no points" : " is another process's"));
  // ParallelLUM takes PCL's non-const pointer; it never modifies the cloud.
  const auto v = impl_->lum.addPointCloud(std::const_pointer_cast<Cloud>(scan),
                                          Eigen::Matrix4f(pose.cast<float>()));
  impl_->lum.setPoseMatrix(v, pose); // keep the double pose
  impl_->trees.emplace_back();
  if (own) {
    setScan(v, scan, std::move(normals), std::move(tree));
    num_points = scan->size();
  }
  impl_->points += num_points;
  borrowed_.push_back(0);
  scans_.push_back(scan);
  poses_.push_back(pose);
  if (j > 0) {
    links_.push_back({static_cast<std::uint32_t>(j - 1), static_cast<std::uint32_t>(j), false});
    impl_->lum.addLink(j, j - 1);
    share(j - 1, owner(j)); // a link is measured where its source is kept
    borrow(j - 1, owner(j));
    if (params_.sequence_constraints && information_pairs > 0.0 && !information.isZero()) {
      // As many pLUM links as the map held scans (docs/design.md, "Sequence constraints").
      const double pairs = 2.0 * static_cast<double>(params_.lum_queries_per_scan) *
                           std::max(1.0, information_scans);
      impl_->lum.addPoseConstraint(j,
                                   j - 1,
                                   poses_[j - 1].inverse() * pose,
                                   information * (pairs / information_pairs),
                                   params_.sequence_cauchy_scale);
      constrained_.push_back(static_cast<std::uint32_t>(j));
    }
  }
}

void
LoopCloser::setScan(std::size_t v,
                    const Cloud::ConstPtr& scan,
                    std::vector<Eigen::Vector3f> normals,
                    std::shared_ptr<const KdTreeIndex> tree)
{
  impl_->lum.setPointCloud(v, std::const_pointer_cast<Cloud>(scan));
  if (params_.lum_point_to_plane && !normals.empty())
    impl_->lum.setPointNormals(v, std::move(normals));
  if (tree)
    impl_->lum.setSearchTree(v, std::move(tree));
  impl_->trees[v] = impl_->lum.getSearchTree(v);
  impl_->kept_points += scan->size();
}

void
LoopCloser::share(std::size_t i, int to)
{
  const int from = owner(i);
  if (!exchange_ || from == to)
    return;
  const int rank = exchange_->rank();
  KeptScan kept;
  if (rank == from) {
    kept.points = scans_[i];
    if (params_.lum_point_to_plane)
      kept.normals = impl_->lum.getPointNormals(i);
  }
  exchange_->send(from, to, kept);
  if (rank != to || impl_->lum.getPointCloud(i)) // held already
    return;
  impl_->lum.setPointCloud(i, std::const_pointer_cast<Cloud>(kept.points));
  if (!kept.normals.empty())
    impl_->lum.setPointNormals(i, std::move(kept.normals));
  impl_->trees[i] = impl_->lum.getSearchTree(i);
  impl_->kept_points += kept.points->size();
}

void
LoopCloser::borrow(std::size_t i, int by)
{
  if (exchange_ && exchange_->rank() == by && !owns(i))
    ++borrowed_[i];
}

void
LoopCloser::release(std::size_t i)
{
  if (owns(i) || borrowed_[i] > 0 || !impl_->lum.getPointCloud(i))
    return;
  impl_->kept_points -= impl_->lum.getPointCloud(i)->size();
  impl_->lum.setPointCloud(i, nullptr);
  impl_->trees[i].reset();
}

std::vector<double>
LoopCloser::firstLook(const std::vector<std::uint32_t>& candidates)
{
  const std::size_t j = scans_.size() - 1;
  std::vector<double> sample; // x, y, z of every step-th point, on the owner
  if (owns(j)) {
    const std::size_t step = std::max<std::size_t>(1, scans_[j]->size() / 256);
    for (std::size_t k = 0; k < scans_[j]->size(); k += step) {
      const auto& p = (*scans_[j])[k];
      sample.insert(sample.end(), {p.x, p.y, p.z});
    }
  }
  const bool elsewhere = std::any_of(
      candidates.begin(), candidates.end(), [&](auto i) { return owner(i) != owner(j); });
  if (elsewhere)
    exchange_->broadcast(owner(j), sample);
  Cloud points;
  for (std::size_t k = 0; k + 2 < sample.size(); k += 3)
    points.push_back(PointT(static_cast<float>(sample[k]),
                            static_cast<float>(sample[k + 1]),
                            static_cast<float>(sample[k + 2])));
  std::vector<double> overlaps(candidates.size(), -1.0);
  for (std::size_t k = 0; k < candidates.size(); ++k) {
    const std::uint32_t i = candidates[k];
    if (owns(i))
      overlaps[k] = overlap(points,
                            Pose(poses_[i].inverse() * poses_[j]),
                            *impl_->trees[i],
                            params_.overlap_distance * 2.0);
  }
  if (exchange_)
    exchange_->maximum(overlaps);
  return overlaps;
}

std::vector<double>
LoopCloser::matchPair(std::uint32_t i, std::size_t j, bool if_conflicting, double search_within)
{
  if (j == kNewest)
    j = scans_.size() - 1;
  share(i, owner(j));
  std::vector<double> result(kMatchSize, 0.0);
  const Cloud::ConstPtr target = !owns(j)    ? nullptr
                                 : scans_[i] ? scans_[i]
                                             : Cloud::ConstPtr(impl_->lum.getPointCloud(i));
  const Pose guess = poses_[i].inverse() * poses_[j];
  const bool agrees =
      target && if_conflicting &&
      mutualConflicts(*target, *scans_[j], guess, up_, params_.overlap_distance) <=
          kMaxLoopConflicts;
  if (target && !agrees) {
    // Centroids of the front end's source voxel: the match only decides whether the link
    // is kept, pLUM then pairs all points.
    const Cloud::Ptr sample =
        filters::voxelCentroid(*scans_[j], source_voxel_size_, num_threads_);
    result = alignPair(i, j, sample, target, guess);
    double error = 0.0;
    if (search_within > 0.0 && !accepts(i, j, result, search_within, error))
      result = searchPair(i, j, sample, target, guess, search_within);
  }
  if (exchange_)
    exchange_->broadcast(owner(j), result);
  return result;
}

std::vector<double>
LoopCloser::alignPair(std::uint32_t i,
                      std::size_t j,
                      const Cloud::ConstPtr& sample,
                      const Cloud::ConstPtr& target,
                      const Pose& start)
{
  std::vector<double> result(kMatchSize, 0.0);
  auto& icp = impl_->icp;
  icp.setInputSource(sample);
  icp.setInputTarget(target);
  Cloud aligned;
  icp.align(aligned, start);
  if (!icp.hasConverged())
    return result;
  const Pose measured = icp.getFinalTransformation();
  result[0] = 1.0;
  Pose::Map(&result[1]) = measured;
  result[17] = overlap(*scans_[j], measured, *impl_->trees[i], params_.overlap_distance);
  if (planar_) // either scan's points in the space the other saw through
    result[18] = mutualConflicts(*target, *scans_[j], measured, up_, params_.overlap_distance);
  return result;
}

std::vector<double>
LoopCloser::searchPair(std::uint32_t i,
                       std::size_t j,
                       const Cloud::ConstPtr& sample,
                       const Cloud::ConstPtr& target,
                       const Pose& guess,
                       double allowed)
{
  std::vector<double> none(kMatchSize, 0.0);
  // The window: the correction accepts() allows, at most a loop's distance.
  const double window = std::min(params_.distance, allowed);
  if (!(window > 2.0 * params_.overlap_distance))
    return none;
  CorrelativeSearchParameters search;
  search.cell = params_.overlap_distance;
  search.radius = window;
  search.max_turn = std::min(kMaxLoopSearchTurn, window / median_range_);
  search.reach = 2.0 * params_.distance;
  search.candidates = kLoopSearchCandidates;
  search.num_threads = num_threads_;
  // Searched in j's predicted frame: the window is about where the poses put j.
  Cloud moved;
  pcl::transformPointCloud(*target, moved, Eigen::Matrix4d(guess.inverse()));
  std::vector<std::vector<double>> accepted;
  for (const Pose& found : correlativeSearch(*sample, moved, up_, search)) {
    std::vector<double> match = alignPair(i, j, sample, target, Pose(guess * found));
    double error = 0.0;
    if (!accepts(i, j, match, allowed, error))
      continue;
    const Pose measured = Pose::Map(&match[1]);
    const bool known = std::any_of(accepted.begin(), accepted.end(), [&](const auto& a) {
      return registration::motionDisplacement(Pose(Pose::Map(&a[1]).inverse() * measured),
                                              median_range_) <= 2.0 * params_.overlap_distance;
    });
    if (!known)
      accepted.push_back(std::move(match));
  }
  // Two distinct poses that both fit (a corridor's repeats): neither is trusted.
  if (accepted.size() != 1)
    return none;
  accepted.front()[19] = 1.0; // searched
  return accepted.front();
}

std::vector<LoopCandidate>
LoopCloser::detect()
{
  std::vector<LoopCandidate> tried;
  const std::size_t j = scans_.size() - 1;
  // One loop link per min_separation / 2 scans: a lingering scanner adds no more.
  const std::size_t spacing = static_cast<std::size_t>(std::max(1, params_.min_separation / 2));
  if (!loop_sources_.empty() && j - loop_sources_.back() < spacing)
    return tried;
  auto candidates =
      loopCandidates(poses_, j, params_.distance, params_.min_separation, median_range_);
  if (candidates.empty())
    return tried;
  // Cheap first look: overlap at the current poses from a sample of the scan; only the
  // best candidate is matched with pICP (paper Sec. VI-C links by distance alone).
  const std::size_t limit = static_cast<std::size_t>(std::max(1, params_.max_candidates));
  if (candidates.size() > limit)
    candidates.resize(limit);
  const std::vector<double> overlaps = firstLook(candidates);
  double best = -1.0;
  std::uint32_t best_i = 0;
  for (std::size_t k = 0; k < candidates.size(); ++k)
    if (overlaps[k] > best)
      best = overlaps[k], best_i = candidates[k];
  LoopCandidate c;
  c.link = {best_i, static_cast<std::uint32_t>(j), true};
  c.overlap = best;
  if (best < 0.5 * params_.min_overlap) {
    if (!planar_) {
      tried.push_back(c);
      return tried;
    }
    // 2D: the poses may have drifted beyond pICP's basin; the nearest is searched.
    best_i = candidates.front();
    c.link.target = best_i;
  }
  const std::uint32_t i = best_i;
  const double allowed = allowedCorrection(i, j);
  const std::vector<double> match = matchPair(i, kNewest, false, planar_ ? allowed : 0.0);
  Pose measured = Pose::Identity();
  if (match[0] != 0.0) {
    measured = Pose::Map(&match[1]);
    c.overlap = match[17];
    c.accepted = accepts(i, j, match, allowed, c.error);
    c.searched = match[19] != 0.0;
  }
  if (c.accepted) {
    c.distributed = params_.distribute_error && c.error > params_.overlap_distance;
    if (c.distributed)
      distributeLoopError(poses_, i, j, measured);
    links_.push_back(c.link);
    loop_sources_.push_back(static_cast<std::uint32_t>(j));
    impl_->lum.addLink(j, i);
    borrow(i, owner(j)); // matchPair brought it where j is kept
  }
  else
    release(i);
  tried.push_back(c);
  return tried;
}

bool
LoopCloser::accepts(std::uint32_t i,
                    std::size_t j,
                    const std::vector<double>& match,
                    double allowed,
                    double& error) const
{
  if (match[0] == 0.0)
    return false;
  const Pose measured = Pose::Map(&match[1]);
  error = registration::motionDisplacement((poses_[i] * measured).inverse() * poses_[j],
                                           median_range_);
  return match[17] >= params_.min_overlap && error <= allowed && match[18] <= kMaxLoopConflicts;
}

double
LoopCloser::allowedCorrection(std::size_t i, std::size_t j) const
{
  const double path = loopPath(poses_,
                               links_,
                               i,
                               j,
                               median_range_,
                               params_.lum_distance / std::max(params_.max_drift, 1e-9));
  return std::max(2.0 * params_.overlap_distance, params_.max_drift * path);
}

std::size_t
LoopCloser::linkRevisits()
{
  std::set<std::pair<std::uint32_t, std::uint32_t>> linked; // (target, source)
  for (const Link& l : links_)
    if (l.loop)
      linked.emplace(l.target, l.source);
  std::size_t added = 0;
  for (std::size_t j = 0; j < scans_.size(); ++j) {
    const auto near =
        loopCandidates(poses_, j, params_.distance, params_.min_separation, median_range_);
    if (near.empty() || linked.count({near.front(), static_cast<std::uint32_t>(j)}))
      continue;
    const std::uint32_t i = near.front();
    const double allowed = allowedCorrection(i, j);
    double error = 0.0;
    if (!accepts(i, j, matchPair(i, j, true, planar_ ? allowed : 0.0), allowed, error)) {
      release(i);
      continue;
    }
    links_.push_back({i, static_cast<std::uint32_t>(j), true});
    impl_->lum.addLink(j, i);
    borrow(i, owner(j)); // matchPair brought it where j is kept
    ++added;
  }
  return added;
}

int
LoopCloser::relax(int max_iterations)
{
  auto& lum = impl_->lum;
  if (poses_.size() < 2)
    return 0;
  lum.setMaxIterations(max_iterations > 0 ? std::min(max_iterations, params_.lum_iterations)
                                          : params_.lum_iterations);
  for (std::size_t v = 0; v < poses_.size(); ++v)
    lum.setPoseMatrix(v, poses_[v]);
  const std::size_t mean = impl_->points / poses_.size();
  const std::size_t per_scan = std::max<std::size_t>(1, params_.lum_queries_per_scan);
  lum.setQueryStep(std::max<std::size_t>(1, mean / per_scan));
  if (exchange_)
    exchange_->relax(lum);
  else
    lum.compute();
  for (std::size_t v = 0; v < poses_.size(); ++v)
    poses_[v] = lum.getPoseMatrix(v);
  return lum.getNumIterationsDone();
}

std::vector<double>
LoopCloser::sequenceChi2() const
{
  std::vector<double> chi2(scans_.size(), -1.0);
  for (std::size_t k = 0; k < constrained_.size(); ++k)
    chi2[constrained_[k]] = impl_->lum.getPoseConstraintChi2(k);
  return chi2;
}

std::size_t
LoopCloser::keptScans() const
{
  std::size_t kept = 0;
  for (std::size_t i = 0; i < scans_.size(); ++i)
    kept += owns(i) || borrowed_[i] > 0 ? 1 : 0;
  return kept;
}

std::size_t
LoopCloser::bytesPerScan() const
{
  if (scans_.empty())
    return 0;
  // Cloud (16 B per PointXYZ), pLUM's k-d tree (shared with the overlap checks: points
  // copied as float[3], an id, ~1/6 node of 16 B each), normals in point-to-plane mode.
  const double tree = 12 + 4 + 16.0 / 6;
  const double per_point = sizeof(PointT) + tree + (params_.lum_point_to_plane ? 12 : 0);
  return static_cast<std::size_t>(per_point * impl_->kept_points / scans_.size()) +
         sizeof(Pose);
}

std::vector<std::uint32_t>
loopCandidates(
    const Poses& poses, std::size_t j, double distance, int min_separation, double range)
{
  std::vector<std::pair<double, std::uint32_t>> near;
  if (min_separation < 1 || j < static_cast<std::size_t>(min_separation) || j >= poses.size())
    return {};
  // Path from scan i to j (translation plus rotation at `range`), walked backwards.
  std::vector<double> path(j + 1, 0.0);
  for (std::size_t k = j; k-- > 0;)
    path[k] = path[k + 1] +
              registration::motionDisplacement(poses[k].inverse() * poses[k + 1], range);
  const Eigen::Vector3d pj = poses[j].topRightCorner<3, 1>();
  for (std::size_t i = 0; i + min_separation <= j; ++i) {
    const double d = (poses[i].topRightCorner<3, 1>() - pj).norm();
    if (d < distance && path[i] >= 2.0 * distance)
      near.emplace_back(d, static_cast<std::uint32_t>(i));
  }
  std::sort(near.begin(), near.end());
  std::vector<std::uint32_t> out;
  for (const auto& n : near)
    out.push_back(n.second);
  return out;
}

double
loopPath(const Poses& poses,
         const std::vector<Link>& links,
         std::size_t i,
         std::size_t j,
         double range,
         double link_length)
{
  // Dijkstra from j over the scans up to the later of the two.
  const std::size_t n = std::max(i, j) + 1;
  if (n > poses.size())
    throw std::out_of_range("loopPath: scan " + std::to_string(n - 1) + " of " +
                            std::to_string(poses.size()));
  std::vector<std::vector<std::uint32_t>> jumps(n);
  for (const Link& l : links)
    if (l.loop && l.source < n && l.target < n) {
      jumps[l.source].push_back(l.target);
      jumps[l.target].push_back(l.source);
    }
  std::vector<double> dist(n, std::numeric_limits<double>::infinity());
  using Entry = std::pair<double, std::size_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> open;
  dist[j] = 0.0;
  open.emplace(0.0, j);
  while (!open.empty()) {
    const auto [d, k] = open.top();
    open.pop();
    if (k == i)
      break;
    if (d > dist[k])
      continue;
    const auto reach = [&, d = d](std::size_t m, double w) {
      if (d + w < dist[m])
        open.emplace(dist[m] = d + w, m);
    };
    if (k > 0)
      reach(k - 1, registration::motionDisplacement(poses[k - 1].inverse() * poses[k], range));
    if (k + 1 < n)
      reach(k + 1, registration::motionDisplacement(poses[k].inverse() * poses[k + 1], range));
    for (const std::uint32_t m : jumps[k])
      reach(m, link_length);
  }
  return dist[i];
}

RevisitConsistency
revisitConsistency(const std::vector<Cloud::ConstPtr>& scans,
                   const Poses& poses,
                   const Parameters& resolved)
{
  const LoopClosureParameters& l = resolved.loops;
  const std::size_t n = std::min(scans.size(), poses.size());
  std::vector<double> conflicts(n, -1.0); // per newer scan; -1: no pair
  parallelFor(n, resolved.num_threads, 8, [&](std::size_t begin, std::size_t end) {
    for (std::size_t j = begin; j < end; ++j) {
      const auto near =
          loopCandidates(poses, j, l.distance, l.min_separation, resolved.median_range);
      if (near.empty() || !scans[j] || !scans[near.front()])
        continue;
      const std::uint32_t i = near.front();
      conflicts[j] = mutualConflicts(*scans[i],
                                     *scans[j],
                                     Pose(poses[i].inverse() * poses[j]),
                                     resolved.guess.up,
                                     l.overlap_distance);
    }
  });
  RevisitConsistency c;
  for (const double share : conflicts) // in scan order: the same sum for any thread count
    if (share >= 0.0) {
      ++c.pairs;
      c.mean_conflicts += share;
      c.conflicting += share > kMaxLoopConflicts ? 1 : 0;
    }
  if (c.pairs > 0)
    c.mean_conflicts /= static_cast<double>(c.pairs);
  return c;
}

void
distributeLoopError(Poses& poses, std::size_t i, std::size_t j, const Pose& measured)
{
  // The correction that moves j to where the loop link puts it, as a rotation about j's
  // position and a translation; scan k gets the share of the path from i to k.
  const Pose target = poses[i] * measured;
  const Eigen::Matrix3d dr =
      target.topLeftCorner<3, 3>() * poses[j].topLeftCorner<3, 3>().transpose();
  const Eigen::AngleAxisd aa(dr);
  const Eigen::Vector3d pivot = poses[j].topRightCorner<3, 1>();
  const Eigen::Vector3d dt = target.topRightCorner<3, 1>() - pivot;
  std::vector<double> along(j - i + 1, 0.0);
  for (std::size_t k = i + 1; k <= j; ++k)
    along[k - i] =
        along[k - i - 1] +
        (poses[k].topRightCorner<3, 1>() - poses[k - 1].topRightCorner<3, 1>()).norm();
  const bool moved = along.back() > 1e-9;
  for (std::size_t k = i + 1; k <= j; ++k) {
    const double s = moved ? along[k - i] / along.back() : double(k - i) / double(j - i);
    const Eigen::Matrix3d r = Eigen::AngleAxisd(s * aa.angle(), aa.axis()).toRotationMatrix();
    Pose& p = poses[k];
    p.topRightCorner<3, 1>() = r * (p.topRightCorner<3, 1>() - pivot) + pivot + s * dt;
    p.topLeftCorner<3, 3>() = r * p.topLeftCorner<3, 3>();
  }
}

} // namespace slam
} // namespace pcl_parallel
