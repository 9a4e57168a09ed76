/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The pcl_pslam pipeline (slam::mapScans) on the simulated scan set: pICP beats the
 * odometry, pLUM closes the loop; its outputs; bad input.
 */
#include <pcl_parallel/evaluation/pose_error.h>
#include <pcl_parallel/sim/simulated_scans.h>
#include <pcl_parallel/slam/mapping.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <map>
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

// slam::mapScans drives slam::Pipeline (test_slam tests the stages): the front end
// beats the odometry in translation and rotation, the loop closes, pLUM cuts the error.
TEST(Pslam, PipelineBeatsOdometryAndClosesTheLoop)
{
  const auto& set = smallSet();
  std::map<std::string, int> last; // per stage: the last `done` reported
  std::string final_stage;
  const pcl_parallel::slam::MappingResult r =
      pcl_parallel::slam::mapScans(set.scans,
                                   set.odometry,
                                   pcl_parallel::slam::Parameters(),
                                   [&](const std::string& stage, int done, int) {
                                     last[stage] = done;
                                     final_stage = stage;
                                   });
  ASSERT_EQ(r.final.size(), set.scans.size());
  EXPECT_EQ(r.final[0], set.truth[0]); // the first pose stays fixed
  EXPECT_EQ(last["icp"], static_cast<int>(set.scans.size()));
  EXPECT_EQ(final_stage, "pLUM"); // the last relaxation reports its own stage
  EXPECT_EQ(last["pLUM"], 1);
  ASSERT_EQ(r.reports.size(), set.scans.size());
  const std::size_t n = set.scans.size();
  bool loop = false;
  for (const auto& [i, j] : r.links)
    loop |= std::max(i, j) > n / 2 && std::min(i, j) < 5; // the end sees the start
  EXPECT_TRUE(loop);

  using pcl_parallel::evaluation::summarizePoseErrors;
  const auto odo = summarizePoseErrors(set.odometry, set.truth);
  const auto icp = summarizePoseErrors(r.icp, set.truth);
  const auto lum = summarizePoseErrors(r.final, set.truth);
  std::printf("mean error: odometry %.3f m %.2f deg, front end %.3f m %.2f deg, final %.3f m "
              "%.2f deg\n",
              odo.distance.mean,
              odo.angle.mean / kDeg,
              icp.distance.mean,
              icp.angle.mean / kDeg,
              lum.distance.mean,
              lum.angle.mean / kDeg);
  EXPECT_LT(icp.distance.mean, 0.5 * odo.distance.mean);
  EXPECT_LT(icp.angle.mean, 0.5 * odo.angle.mean);
  EXPECT_LT(lum.distance.max, 0.1 * odo.distance.max);
  EXPECT_LT(lum.distance.max, 0.05);
  EXPECT_LT(lum.angle.max, 0.25 * kDeg);
}

TEST(Pslam, BadInputIsAClearError)
{
  using pcl_parallel::slam::Cloud;
  using pcl_parallel::slam::mapScans;
  using pcl_parallel::slam::Poses;
  const auto& set = smallSet();
  const std::vector<Cloud::Ptr> one(set.scans.begin(), set.scans.begin() + 1);
  const Poses one_pose(set.truth.begin(), set.truth.begin() + 1);
  EXPECT_THROW(mapScans(one, one_pose, {}), std::invalid_argument);
  std::vector<Cloud::Ptr> two(set.scans.begin(), set.scans.begin() + 2);
  EXPECT_THROW(mapScans(two, one_pose, {}), std::invalid_argument);
  Poses bad(set.truth.begin(), set.truth.begin() + 2);
  bad[1](0, 3) = std::nan("");
  EXPECT_THROW(mapScans(two, bad, {}), std::invalid_argument);
  two[1].reset(new Cloud);
  const Poses two_poses(set.truth.begin(), set.truth.begin() + 2);
  EXPECT_THROW(mapScans(two, two_poses, {}), std::invalid_argument);
}

} // namespace
