/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/io/scan_directory.h>
#include <pcl_parallel/registration/icp.h>
#include <pcl_parallel/slam/matcher.h>
#include <pcl_parallel/slam/pose_graph_se2.h>
#include <pcl_parallel/slam/reducer.h>

#include <stdexcept>

namespace pcl_parallel {
namespace slam {

namespace {

/** The (x, y, yaw) block of a planar match's information (matchInformation, translation
 *  first), exactly symmetric as g2o's upper triangle takes it. */
Eigen::Matrix3d
planarInformation(const ParallelIterativeClosestPoint<PointT, MapPoint, float>& icp)
{
  const Information full =
      matchInformation(icp.getFinalHessian(), icp.getFinalError(), icp.getFinalWeight(), 3.0);
  const int rows[3] = {0, 1, 5};
  Eigen::Matrix3d out;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      out(i, j) = full(rows[i], rows[j]);
  return 0.5 * (out + out.transpose());
}

} // namespace

std::vector<io::G2oEdgeSe2>
measureLinksSe2(const io::ScanDirectory& scans, const MappingResult& result)
{
  const Parameters& p = result.parameters;
  if (!p.planar)
    throw std::invalid_argument("measureLinksSe2: the run was not planar");
  const Reducer reducer(p);
  std::vector<ReducedScan> reduced(scans.size());
  for (std::size_t k = 0; k < scans.size(); ++k) {
    reduced[k] = reducer.reduce(*io::readScan(scans, k));
    reducer.describe(reduced[k]);
  }
  ParallelIterativeClosestPoint<PointT, MapPoint, float> icp;
  icp.setNumberOfThreads(p.num_threads);
  icp.setPlanar(true);
  icp.setUsePointToPlane(p.matcher.point_to_plane);
  icp.setUseTargetNormalFields(true);
  icp.setMaxCorrespondenceDistance(p.loops.lum_final_distance);
  icp.setMaximumIterations(p.loops.icp_iterations);
  icp.setTransformationEpsilon(p.loops.icp_epsilon);
  std::vector<io::G2oEdgeSe2> edges;
  for (const auto& [source, target] : result.links) {
    icp.setInputTarget(withNormals(reduced[target]));
    icp.setInputSource(reducer.source(reduced[source]));
    const Pose guess = result.final[target].inverse() * result.final[source];
    Cloud aligned;
    icp.alignDouble(aligned, guess);
    io::G2oEdgeSe2 e;
    e.from = target;
    e.to = source;
    e.measurement = icp.hasConverged() ? Pose(icp.getFinalTransformationDouble()) : guess;
    e.information = icp.hasConverged() ? planarInformation(icp) : Eigen::Matrix3d::Zero();
    edges.push_back(e);
  }
  return edges;
}

} // namespace slam
} // namespace pcl_parallel
