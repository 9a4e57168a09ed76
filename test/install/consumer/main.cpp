/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Consumer of the installed package (ctest install_consumer); also the usage example in
 * README.md. Exits non-zero if a search or the registration gives a wrong answer.
 */
#include <pcl_parallel/filters/voxel_grid.h>
#include <pcl_parallel/registration/correspondence_estimation.h>
#include <pcl_parallel/search/kdtree.h>
#include <pcl_parallel/slam/pipeline.h>
#include <pcl_parallel/slam/read_ahead.h>

#include <pcl/common/transforms.h>
#include <pcl/registration/icp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

int
main()
{
  using Cloud = pcl::PointCloud<pcl::PointXYZ>;
  Cloud::Ptr target(new Cloud), source(new Cloud);
  for (int i = 0; i < 20; ++i) // a 20 x 20 x 5 grid, 10 cm spacing
    for (int j = 0; j < 20; ++j)
      for (int k = 0; k < 5; ++k)
        target->push_back(pcl::PointXYZ(0.1f * i, 0.1f * j, 0.1f * k));

  // Drop-in for pcl::search::KdTree, built and batch-searched in parallel.
  pcl_parallel::search::KdTree<pcl::PointXYZ>::Ptr tree(
      new pcl_parallel::search::KdTree<pcl::PointXYZ>);
  tree->setInputCloud(target);
  pcl::Indices nn(1);
  std::vector<float> nn_sqr(1);
  if (tree->nearestKSearch(pcl::PointXYZ(0.51f, 0.49f, 0.2f), 1, nn, nn_sqr) != 1 ||
      (*target)[nn[0]].getVector3fMap() != Eigen::Vector3f(0.5f, 0.5f, 0.2f)) {
    std::fprintf(stderr, "nearestKSearch: wrong neighbour\n");
    return 1;
  }

  // Parallel closest-point search inside PCL's ICP.
  Eigen::Affine3f motion(Eigen::Translation3f(0.02f, -0.03f, 0.01f));
  pcl::transformPointCloud(*target, *source, motion);
  using Estimation =
      pcl_parallel::registration::ParallelCorrespondenceEstimation<pcl::PointXYZ,
                                                                   pcl::PointXYZ>;
  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
  icp.setCorrespondenceEstimation(Estimation::Ptr(new Estimation));
  icp.setSearchMethodTarget(tree, true); // reuse the tree built above
  icp.setInputSource(source);
  icp.setInputTarget(target);
  icp.setMaximumIterations(50);
  Cloud aligned;
  icp.align(aligned);
  const Eigen::Vector3f t = icp.getFinalTransformation().block<3, 1>(0, 3);
  const float err = (t + motion.translation()).norm();
  std::printf("ICP converged=%d, translation error %.2e\n", icp.hasConverged(), err);
  if (!icp.hasConverged() || err >= 1e-3f)
    return 1;

  // The mapping pipeline, fed one scan at a time: a room seen from two places 0.2 m apart.
  Cloud room;
  for (int i = 0; i <= 40; ++i)
    for (int j = 0; j <= 20; ++j) {
      const float u = 0.1f * i - 2.0f, v = 0.1f * j - 1.0f;
      room.push_back(pcl::PointXYZ(u, 2.0f, v));                // wall, y = 2
      room.push_back(pcl::PointXYZ(2.5f, 0.1f * i - 2.0f, v));  // wall, x = 2.5
      room.push_back(pcl::PointXYZ(u, 0.1f * j - 1.0f, -1.0f)); // floor
    }
  Cloud moved;
  pcl::transformPointCloud(room, moved, Eigen::Affine3f(Eigen::Translation3f(-0.2f, 0, 0)));
  pcl_parallel::slam::Pipeline pipeline;
  const Cloud* scans[] = {&room, &moved}; // as if from files: the next read while one matches
  pcl_parallel::slam::ReadAhead read(
      [&](std::size_t k) {
        pcl_parallel::slam::SourceScan s;
        s.cloud.reset(new Cloud(*scans[k]));
        return s;
      },
      2);
  for (std::size_t k = 0; k < 2; ++k)
    pipeline.addScan(*read(k).cloud); // no odometry: constant velocity from standing still
  pipeline.finish();
  const pcl_parallel::slam::Poses& poses = pipeline.poses();
  const double dx = poses[1](0, 3);
  std::printf("pipeline: scan 1 at x = %.4f (truth 0.2)\n", dx);
  if (std::abs(dx - 0.2) >= 0.01)
    return 1;

  // The full-resolution map: a second pass, each scan as the map at these poses shows it
  // (deskewed there with Parameters::deskew), one centroid per 5 cm voxel.
  pcl_parallel::filters::VoxelCentroidMap map(0.05);
  for (std::size_t k = 0; k < 2; ++k)
    map.add(*pcl_parallel::slam::mapFrame(*scans[k], {}, poses, {}, k, pipeline.parameters()),
            poses[k]);
  const Cloud::Ptr merged = map.centroids();
  // Both scans land on the room: every centroid lies on its points (5 cm voxels, 10 cm grid).
  tree->setInputCloud(Cloud::ConstPtr(new Cloud(room)));
  float worst = 0.0f;
  for (const auto& p : *merged) {
    tree->nearestKSearch(p, 1, nn, nn_sqr);
    worst = std::max(worst, std::sqrt(nn_sqr[0]));
  }
  std::printf("map: %zu points, at most %.3f m off the room\n", merged->size(), worst);
  return !merged->empty() && worst < 0.01f ? 0 : 1;
}
