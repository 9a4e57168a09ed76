/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/filters/voxel_grid.h>
#include <pcl_parallel/registration/icp.h>
#include <pcl_parallel/slam/front_end.h>
#include <pcl_parallel/slam/preprocess.h>

#include <pcl/common/transforms.h>

namespace pcl_parallel {
namespace slam {

struct FrontEnd::Registration {
  ParallelIterativeClosestPoint<PointT, PointT, double> icp;
};

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

  const Cloud::Ptr frame = params_.deskew ? deskew(scan, motion, params_.num_threads)
                                          : Cloud::Ptr(new Cloud(scan));
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
    const Cloud::ConstPtr target = to_map ? map_.cloud() : Cloud::ConstPtr(previous_);
    if (target != target_) // the tree is rebuilt only for a new target
      icp.setInputTarget(target_ = target);
    Cloud aligned;
    icp.align(aligned, r.prediction);
    r.converged = icp.hasConverged();
    if (r.converged) {
      r.pose = icp.getFinalTransformation();
      r.fitness = icp.getFitnessScore(params_.max_correspondence_distance);
    }
  }
  velocity_ = first ? Pose::Identity() : Pose(pose_.inverse() * r.pose);
  pose_ = r.pose;

  Cloud::Ptr world(new Cloud);
  pcl::transformPointCloud(*r.reduced, *world, pose_);
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
    Cloud::Ptr moved(new Cloud);
    pcl::transformPointCloud(*previous_, *moved, correction);
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
