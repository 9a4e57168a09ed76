/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/uos.h>
#include <pcl_parallel/slam/types.h>

#include <cstdio>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace bench {

/** A simulated preset as `pcl_pslam simulate` writes it (sim::writeScanSet), read scan by
 *  scan as pcl_pslam reads it: uos .3d in cm (scaled to m) with its .pose, or KITTI .bin
 *  with a line of odometry.txt. */
struct PresetReader {
  std::string dir;
  bool uos;
  std::vector<Eigen::Matrix4d> odometry; // kitti

  PresetReader(const std::string& directory, bool uos_format)
      : dir(directory)
      , uos(uos_format)
  {
    if (!uos)
      odometry = io::loadKittiPoses(dir + "/odometry.txt");
  }

  slam::Cloud::Ptr
  scan(std::size_t i, Eigen::Matrix4d& pose) const
  {
    char name[32];
    if (uos) {
      std::snprintf(name, sizeof(name), "/scan%03zu", i);
      auto cloud = io::loadUosScan(dir + name + ".3d");
      for (auto& p : *cloud)
        p.getVector3fMap() *= 0.01f;
      pose = io::loadUosPose(dir + name + ".pose");
      pose.topRightCorner<3, 1>() *= 0.01;
      return cloud;
    }
    std::snprintf(name, sizeof(name), "/%06zu.bin", i);
    pose = odometry.at(i);
    return io::loadKittiScan(dir + name);
  }
};

} // namespace bench
} // namespace pcl_parallel
