/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The pcl_pslam pipeline on the simulated scan set: pICP beats the odometry, pLUM closes
 * the loop; its outputs; bad input.
 */
#include "slam_pipeline.h"

#include <pcl_parallel/sim/simulated_scans.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <stdexcept>

namespace {

constexpr double kDeg = M_PI / 180.0;

/** A smaller floor than the demo's (20 x 14 m, ~38 scans), once per test binary. */
const pcl_parallel::sim::SimulatedScanSet&
smallSet()
{
  static const pcl_parallel::sim::SimulatedScanSet set = [] {
    pcl_parallel::sim::SimulationParameters p;
    p.outer_length = 20.0;
    p.outer_width = 14.0;
    return pcl_parallel::sim::simulateScanSet(p);
  }();
  return set;
}

TEST(Pslam, PipelineBeatsOdometryAndClosesTheLoop)
{
  const auto& set = smallSet();
  int last_lum = 0;
  const pcl_pslam::Result r = pcl_pslam::run(set.scans,
                                             set.odometry,
                                             pcl_pslam::Parameters(),
                                             [&](const std::string& stage, int done, int) {
                                               if (stage == "lum")
                                                 last_lum = done;
                                             });
  ASSERT_EQ(r.final.size(), set.scans.size());
  EXPECT_EQ(r.final[0], set.truth[0]); // the first pose stays fixed
  EXPECT_EQ(last_lum, r.lum_iterations);
  const std::size_t n = set.scans.size();
  bool loop = false;
  for (const auto& [i, j] : r.links)
    loop |= std::max(i, j) + 1 == n && std::min(i, j) < 3; // the end sees the start
  EXPECT_TRUE(loop);

  const auto odo = pcl_pslam::poseErrors(set.odometry, set.truth);
  const auto icp = pcl_pslam::poseErrors(r.icp, set.truth);
  const auto lum = pcl_pslam::poseErrors(r.final, set.truth);
  std::printf("max / mean translation error: odometry %.3f / %.3f m, pICP %.3f / %.3f m, "
              "pLUM %.3f / %.3f m (max rotation %.2f, %.2f, %.2f deg)\n",
              odo.max_trans,
              odo.mean_trans,
              icp.max_trans,
              icp.mean_trans,
              lum.max_trans,
              lum.mean_trans,
              odo.max_rot / kDeg,
              icp.max_rot / kDeg,
              lum.max_rot / kDeg);
  // Measured: odometry 0.52 m / 1.8 deg, pICP 0.52 m / 3.6 deg (its per-step rotation
  // errors, 0.03-0.28 deg, mostly share one sign on these sampled surfaces, so they add
  // up), pLUM 0.017 m / 0.06 deg.
  EXPECT_LT(icp.mean_trans, odo.mean_trans);
  EXPECT_LT(lum.max_trans, 0.1 * odo.max_trans);
  EXPECT_LT(lum.max_trans, 0.05);
  EXPECT_LT(lum.max_rot, 0.25 * kDeg);
}

// The whole pipeline gives bit-identical poses for 1 and 2 threads.
TEST(Pslam, SameResultForAnyThreadCount)
{
  const auto& set = smallSet();
  const std::vector<pcl_pslam::Cloud::Ptr> scans(set.scans.begin(), set.scans.begin() + 8);
  const pcl_pslam::Poses odometry(set.odometry.begin(), set.odometry.begin() + 8);
  pcl_pslam::Parameters params;
  params.lum_iterations = 5;
  params.num_threads = 1;
  const pcl_pslam::Result one = pcl_pslam::run(scans, odometry, params);
  params.num_threads = 2;
  const pcl_pslam::Result two = pcl_pslam::run(scans, odometry, params);
  for (std::size_t i = 0; i < scans.size(); ++i) {
    EXPECT_EQ(one.icp[i], two.icp[i]) << "scan " << i;
    EXPECT_EQ(one.final[i], two.final[i]) << "scan " << i;
  }
}

TEST(Pslam, OutputsAreWritten)
{
  const auto& set = smallSet();
  const auto dir = std::filesystem::temp_directory_path() / "pcl_pslam_test_outputs";
  std::filesystem::create_directories(dir);
  const pcl_pslam::Poses poses(set.truth.begin(), set.truth.begin() + 5);
  pcl_pslam::writePoses((dir / "poses.txt").string(), poses);
  std::ifstream in(dir / "poses.txt");
  for (const auto& p : poses) { // 12 numbers per pose, row-major [R | t]
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        ASSERT_TRUE(in >> m(r, c));
    EXPECT_LT((m - p).norm(), 1e-8);
  }
  double extra;
  EXPECT_FALSE(in >> extra);

  const std::vector<pcl_pslam::Cloud::Ptr> scans(set.scans.begin(), set.scans.begin() + 5);
  const auto map = pcl_pslam::mergedMap(scans, poses, 0.1);
  ASSERT_GT(map->size(), 1000u);
  const std::string png = (dir / "map.png").string();
  pcl_pslam::writeTopView(png, *map, poses, 2, 400);
  std::ifstream img(png, std::ios::binary);
  unsigned char sig[8] = {};
  img.read(reinterpret_cast<char*>(sig), 8);
  const unsigned char expected[8] = {0x89, 'P', 'N', 'G', 0x0d, 0x0a, 0x1a, 0x0a};
  EXPECT_TRUE(std::equal(sig, sig + 8, expected)) << "not a PNG";
  EXPECT_THROW(pcl_pslam::writeTopView("/nonexistent/dir/map.png", *map, poses),
               std::runtime_error);
  EXPECT_THROW(pcl_pslam::writePoses("/nonexistent/dir/poses.txt", poses), std::runtime_error);
  std::filesystem::remove_all(dir);
}

TEST(Pslam, BadInputIsAClearError)
{
  const auto& set = smallSet();
  const std::vector<pcl_pslam::Cloud::Ptr> one(set.scans.begin(), set.scans.begin() + 1);
  const pcl_pslam::Poses one_pose(set.truth.begin(), set.truth.begin() + 1);
  EXPECT_THROW(pcl_pslam::run(one, one_pose, {}), std::invalid_argument);
  std::vector<pcl_pslam::Cloud::Ptr> two(set.scans.begin(), set.scans.begin() + 2);
  EXPECT_THROW(pcl_pslam::run(two, one_pose, {}), std::invalid_argument);
  pcl_pslam::Poses bad(set.truth.begin(), set.truth.begin() + 2);
  bad[1](0, 3) = std::nan("");
  EXPECT_THROW(pcl_pslam::run(two, bad, {}), std::invalid_argument);
  two[1].reset(new pcl_pslam::Cloud);
  const pcl_pslam::Poses two_poses(set.truth.begin(), set.truth.begin() + 2);
  EXPECT_THROW(pcl_pslam::run(two, two_poses, {}), std::invalid_argument);
}

} // namespace
