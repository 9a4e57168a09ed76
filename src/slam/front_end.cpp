/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/filters/voxel_grid.h>
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/normal_estimation.h>
#include <pcl_parallel/registration/adaptive_threshold.h>
#include <pcl_parallel/registration/icp.h>
#include <pcl_parallel/slam/front_end.h>
#include <pcl_parallel/slam/preprocess.h>

#include <pcl/common/transforms.h>

#include <cmath>
#include <vector>

namespace pcl_parallel {
namespace slam {

struct FrontEnd::Registration {
  // The target's normals come with it (setUseTargetNormalFields): estimated once per scan.
  ParallelIterativeClosestPoint<PointT, MapPoint, float> icp;
  std::unique_ptr<registration::AdaptiveThreshold> threshold;
};

namespace {

/** The points with their normals (PCA of the 10 nearest neighbours in the same scan);
 *  points without a normal (too few neighbours) are left out. */
MapCloud::Ptr
withNormals(const Cloud& scan, unsigned num_threads)
{
  MapCloud::Ptr out(new MapCloud);
  if (scan.empty())
    return out;
  KdTreeIndex tree;
  tree.build(
      scan.front().data, scan.size(), sizeof(PointT) / sizeof(float), nullptr, num_threads);
  std::vector<float> normals;
  estimateNormals(tree, 10, num_threads, normals);
  std::vector<std::uint32_t> position(scan.size(), KdTreeIndex::kInvalid);
  for (std::uint32_t pos = 0; pos < tree.size(); ++pos)
    position[tree.id(pos)] = pos;
  out->reserve(scan.size());
  for (std::size_t i = 0; i < scan.size(); ++i) {
    const std::uint32_t pos = position[i];
    if (pos == KdTreeIndex::kInvalid || !std::isfinite(normals[3 * pos]))
      continue;
    MapPoint p;
    p.getVector3fMap() = scan[i].getVector3fMap();
    p.getNormalVector3fMap() = Eigen::Vector3f::Map(&normals[3 * pos]);
    p.curvature = 0.0f;
    out->push_back(p);
  }
  return out;
}

} // namespace

FrontEnd::FrontEnd(const FrontEndParameters& params)
    : params_(params)
    , icp_(new Registration)
    , map_(params.map_voxel_size, params.map_distance, params.map_points_per_voxel)
{
  auto& icp = icp_->icp;
  icp.setNumberOfThreads(params.num_threads);
  icp.setMaxCorrespondenceDistance(params.max_correspondence_distance);
  icp.setMaximumIterations(params.max_iterations);
  icp.setTransformationEpsilon(params.transformation_epsilon);
  icp.setUsePointToPlane(params.point_to_plane);
  if (params.adaptive_threshold) // KISS-ICP: min motion 0.1 m at 1 m voxels, max range
    icp_->threshold.reset(new registration::AdaptiveThreshold(
        params.max_correspondence_distance, 0.1 * params.map_voxel_size, params.map_distance));
}

double
FrontEnd::gate() const
{
  return icp_->threshold ? std::min(params_.max_correspondence_distance,
                                    icp_->threshold->correspondenceDistance())
                         : params_.max_correspondence_distance;
}

FrontEnd::~FrontEnd() = default;

FrontEndResult
FrontEnd::track(const Cloud& scan, const std::optional<Pose>& odometry)
{
  FrontEndResult r;
  // Motion prior: the odometry step, else constant velocity (KISS-ICP Sec. III-B).
  const bool first = scans_++ == 0;
  Pose motion = velocity_;
  if (odometry && last_odometry_)
    motion = last_odometry_->inverse() * *odometry;
  if (odometry)
    last_odometry_ = odometry;
  r.prediction = first ? (odometry ? *odometry : Pose::Identity()) : Pose(pose_ * motion);

  const Cloud::Ptr frame =
      params_.deskew ? deskew(scan, motion, params_.num_threads) : Cloud::Ptr(new Cloud(scan));
  r.reduced = filters::voxelCentroid(*frame, params_.voxel_size, params_.num_threads);
  const auto source =
      filters::voxelCentroid(*r.reduced, params_.source_voxel_size, params_.num_threads);
  r.source_points = source->size();

  r.pose = r.prediction;
  const bool to_map = params_.target == MatchTarget::kLocalMap;
  const bool has_target = to_map ? !map_.empty() : previous_ && !previous_->empty();
  if (!first && has_target && !source->empty()) {
    auto& icp = icp_->icp;
    icp.setInputSource(source);
    const MapCloud::ConstPtr target = to_map ? map_.cloud() : MapCloud::ConstPtr(previous_);
    if (target != target_) // the tree is rebuilt only for a new target
      icp.setInputTarget(target_ = target);
    r.gate = gate();
    icp.setMaxCorrespondenceDistance(r.gate);
    if (icp_->threshold) // Geman-McClure, scale sigma / 3 (KISS-ICP)
      icp.setRobustKernel({registration::RobustKernel::Type::kGemanMcClure, r.gate / 9.0});
    Cloud aligned;
    icp.alignDouble(aligned, r.prediction);
    r.converged = icp.hasConverged();
    if (r.converged) {
      r.pose = icp.getFinalTransformationDouble();
      r.fitness = icp.getFitnessScore(r.gate);
      if (icp_->threshold) // how far the match moved the scan from the prior
        icp_->threshold->updateModelDeviation(r.prediction.inverse() * r.pose);
    }
  }
  velocity_ = first ? Pose::Identity() : Pose(pose_.inverse() * r.pose);
  pose_ = r.pose;

  // The scan's normals, once (k = 10 neighbours in the reduced scan), then into the world.
  const MapCloud::Ptr world = withNormals(*r.reduced, params_.num_threads);
  pcl::transformPointCloudWithNormals(*world, *world, pose_);
  if (to_map)
    map_.update(*world, pose_.topRightCorner<3, 1>());
  else
    previous_ = world;
  return r;
}

void
FrontEnd::applyCorrection(const Pose& correction)
{
  pose_ = correction * pose_;
  map_.transform(correction);
  if (previous_) { // a new object, so pICP rebuilds its target tree
    MapCloud::Ptr moved(new MapCloud);
    pcl::transformPointCloudWithNormals(*previous_, *moved, correction);
    previous_ = moved;
  }
}

void
FrontEnd::setLastPose(const Pose& pose)
{
  applyCorrection(pose * pose_.inverse());
}

} // namespace slam
} // namespace pcl_parallel
