/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * slam::correlativeSearch on a small synthetic site (light enough for ThreadSanitizer):
 * it finds the pose between two stations from nothing but their points, about any
 * vertical axis, the same for any thread count; bad settings throw. And slam::FreeSpace,
 * by which the search judges its candidates. On the simulator's terrestrial scans:
 * test_slam, CorrelativeSearch.
 */
#include <pcl_parallel/slam/correlative_search.h>
#include <pcl_parallel/slam/overlap.h>

#include <pcl/common/transforms.h>

#include <Eigen/Geometry>

#include <cmath>
#include <gtest/gtest.h>
#include <limits>
#include <random>
#include <stdexcept>

namespace {

using namespace pcl_parallel;
using slam::Cloud;
using slam::Pose;

constexpr double kDeg = M_PI / 180.0;

/** A courtyard, z up: ground, walls of a 40 x 26 m rectangle with a recess, and pillars
 *  at irregular places, points every ~0.25 m (world frame). */
Cloud
courtyard()
{
  Cloud world;
  const auto add = [&world](double x, double y, double z) {
    world.push_back(
        pcl::PointXYZ(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)));
  };
  const double step = 0.25;
  for (double x = -20.0; x <= 20.0; x += step)
    for (double y = -13.0; y <= 13.0; y += step) {
      add(x, y, -1.5);
      const bool recess = x > 4.0 && x < 9.0;
      for (double z = -1.5; z <= 4.0; z += step) {
        if (std::abs(y) < 0.5 * step)
          continue;
        if (std::abs(std::abs(x) - 20.0) < 0.5 * step)
          add(x, y, z);
        if (std::abs(y + 13.0) < 0.5 * step)
          add(x, recess ? -16.0 : -13.0, z);
        if (std::abs(y - 13.0) < 0.5 * step)
          add(x, y, z);
      }
    }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> ux(-17.0, 17.0), uy(-10.0, 10.0);
  for (int k = 0; k < 9; ++k) {
    const double cx = ux(rng), cy = uy(rng), r = 0.3 + 0.1 * k;
    for (double a = 0.0; a < 2.0 * M_PI; a += step / r)
      for (double z = -1.5; z <= 3.0; z += step)
        add(cx + r * std::cos(a), cy + r * std::sin(a), z);
  }
  return world;
}

/** The site's points within `range` of a station, in the station's frame. */
Cloud
scanFrom(const Cloud& world, const Pose& station, double range)
{
  Cloud scan;
  const Pose to_station = station.inverse();
  for (const auto& p : world) {
    const Eigen::Vector3d q =
        (to_station * p.getVector3fMap().cast<double>().homogeneous()).head<3>();
    if (q.norm() <= range)
      scan.push_back(pcl::PointXYZ(
          static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())));
  }
  return scan;
}

Pose
station(double heading, double x, double y, double z)
{
  Pose p = Pose::Identity();
  p.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  p.topRightCorner<3, 1>() = Eigen::Vector3d(x, y, z);
  return p;
}

/** The nearest candidate's distance and angle from `truth`. */
std::pair<double, double>
nearest(const std::vector<Pose>& candidates, const Pose& truth)
{
  double distance = std::numeric_limits<double>::infinity(), angle = 0.0;
  for (const Pose& c : candidates) {
    const Pose e = truth.inverse() * c;
    if (const double d = e.topRightCorner<3, 1>().norm(); d < distance) {
      distance = d;
      angle = Eigen::AngleAxisd(Eigen::Matrix3d(e.topLeftCorner<3, 3>())).angle();
    }
  }
  return {distance, angle};
}

// Two stations 9.5 m and 110 degrees apart (a step no prediction gives): a candidate
// lies within pICP's reach (2 cells, 5 degrees; measured 2.5 degrees at most), and with
// the site turned so that y is up (3DTK's frame) and `up` = y, the same.
TEST(CorrelativeSearch, FindsTheStationsPoseAboutAnyVerticalAxis)
{
  const Cloud world = courtyard();
  const Pose a = station(0.3, -6.0, 2.0, 0.0), b = station(0.3 + 110.0 * kDeg, 3.0, -1.0, 0.2);
  slam::CorrelativeSearchParameters params;
  params.cell = 0.4;
  params.num_threads = 2;
  const Pose truth = a.inverse() * b;
  const auto z_up = slam::correlativeSearch(
      scanFrom(world, b, 25.0), scanFrom(world, a, 25.0), Eigen::Vector3d::UnitZ(), params);
  ASSERT_FALSE(z_up.empty());
  EXPECT_LE(z_up.size(), params.candidates);
  const auto [d, angle] = nearest(z_up, truth);
  EXPECT_LT(d, 2.0 * params.cell);
  EXPECT_LT(angle, 5.0 * kDeg);

  // The same site in a frame whose vertical is y: z -> y.
  Pose turn = Pose::Identity();
  turn.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(-M_PI / 2.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
  Cloud turned;
  for (const auto& p : world) {
    const Eigen::Vector3d q =
        (turn * p.getVector3fMap().cast<double>().homogeneous()).head<3>();
    turned.push_back(pcl::PointXYZ(
        static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())));
  }
  const Pose ta = turn * a * turn.inverse(), tb = turn * b * turn.inverse();
  const auto y_up = slam::correlativeSearch(
      scanFrom(turned, tb, 25.0), scanFrom(turned, ta, 25.0), Eigen::Vector3d::UnitY(), params);
  const auto [dy, angle_y] = nearest(y_up, ta.inverse() * tb);
  EXPECT_LT(dy, 2.0 * params.cell);
  EXPECT_LT(angle_y, 5.0 * kDeg);
  // About the wrong axis the search cannot find it.
  const auto wrong = slam::correlativeSearch(
      scanFrom(turned, tb, 25.0), scanFrom(turned, ta, 25.0), Eigen::Vector3d::UnitZ(), params);
  EXPECT_GT(nearest(wrong, ta.inverse() * tb).first, 1.0);
}

// A window about a predicted pose (loop closing): the target moved into the frame the
// prediction gives the source, which is 1.2 m and 14 degrees off. A window of 2 m and
// 20 degrees finds the truth (within pICP's reach); one of 5 degrees returns only
// headings within it (a quarter step of fine search beyond), so never the truth.
TEST(CorrelativeSearch, WindowAboutAPredictedPose)
{
  const Cloud world = courtyard();
  const Pose a = station(0.2, -4.0, 1.0, 0.0), b = station(0.9, 5.0, -2.0, 0.0);
  const Pose truth = a.inverse() * b;                               // b in a's frame
  const Pose guess = truth * station(14.0 * kDeg, 1.0, -0.65, 0.0); // off by 1.2 m, 14 deg
  Cloud target; // a's scan seen from where the guess puts b
  pcl::transformPointCloud(scanFrom(world, a, 25.0), target, Eigen::Matrix4d(guess.inverse()));
  slam::CorrelativeSearchParameters params;
  params.cell = 0.4;
  params.radius = 2.0;
  params.reach = 25.0;
  params.max_turn = 20.0 * kDeg;
  params.num_threads = 2;
  const Cloud source = scanFrom(world, b, 25.0);
  const auto found = slam::correlativeSearch(source, target, Eigen::Vector3d::UnitZ(), params);
  const auto [d, angle] = nearest(found, guess.inverse() * truth);
  EXPECT_LT(d, 2.0 * params.cell);
  EXPECT_LT(angle, 5.0 * kDeg);
  params.max_turn = 5.0 * kDeg;
  const auto narrow = slam::correlativeSearch(source, target, Eigen::Vector3d::UnitZ(), params);
  ASSERT_FALSE(narrow.empty());
  for (const Pose& c : narrow) {
    EXPECT_LE(Eigen::AngleAxisd(Eigen::Matrix3d(c.topLeftCorner<3, 3>())).angle(),
              params.max_turn + 2.5 * kDeg + 1e-9);
    const double moved = c.topRightCorner<2, 1>().norm();
    EXPECT_LE(moved, params.radius + 3.0 * params.cell);
  }
  EXPECT_GT(nearest(narrow, guess.inverse() * truth).second, 5.0 * kDeg);
}

// Headings are scored in parallel, each into its own row: any thread count, the same
// candidates.
TEST(CorrelativeSearch, SameCandidatesForAnyThreadCount)
{
  const Cloud world = courtyard();
  const Cloud target = scanFrom(world, station(0.0, 0.0, 0.0, 0.0), 25.0);
  const Cloud source = scanFrom(world, station(-40.0 * kDeg, 5.0, 4.0, 0.0), 25.0);
  slam::CorrelativeSearchParameters params;
  params.cell = 0.4;
  params.num_threads = 1;
  const auto one = slam::correlativeSearch(source, target, Eigen::Vector3d::UnitZ(), params);
  for (unsigned threads : {2u, 3u}) {
    params.num_threads = threads;
    EXPECT_EQ(one, slam::correlativeSearch(source, target, Eigen::Vector3d::UnitZ(), params))
        << threads;
  }
}

// Settings it cannot search with are errors; scans with nothing to match give nothing.
TEST(CorrelativeSearch, BadSettingsThrowEmptyScansGiveNothing)
{
  const Cloud scan = scanFrom(courtyard(), Pose::Identity(), 25.0);
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  slam::CorrelativeSearchParameters p;
  EXPECT_TRUE(slam::correlativeSearch(scan, Cloud(), z, p).empty());
  EXPECT_TRUE(slam::correlativeSearch(Cloud(), scan, z, p).empty());
  Cloud far; // beyond the search's reach of the target's points
  far.push_back(pcl::PointXYZ(1e6f, 0.0f, 0.0f));
  EXPECT_TRUE(slam::correlativeSearch(far, scan, z, p).empty());
  EXPECT_THROW(slam::correlativeSearch(scan, scan, Eigen::Vector3d::Zero(), p),
               std::invalid_argument);
  for (double cell : {0.0, -1.0, std::nan("")}) {
    p.cell = cell;
    EXPECT_THROW(slam::correlativeSearch(scan, scan, z, p), std::invalid_argument) << cell;
  }
  p = slam::CorrelativeSearchParameters();
  p.headings = 0;
  EXPECT_THROW(slam::correlativeSearch(scan, scan, z, p), std::invalid_argument);
  p.headings = 72;
  for (double* bad : {&p.radius, &p.max_turn, &p.reach})
    for (double value : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
      const double kept = *bad;
      *bad = value;
      EXPECT_THROW(slam::correlativeSearch(scan, scan, z, p), std::invalid_argument) << value;
      *bad = kept;
    }
  p = slam::CorrelativeSearchParameters();
  p.max_points = 0; // was a division by zero
  EXPECT_THROW(slam::correlativeSearch(scan, scan, z, p), std::invalid_argument);
}

// A wall 10 m ahead of the scanner (x), 4 x 4 m: points in front of it along a beam
// contradict it, points on it (within the margin), behind it or where no beam returned
// do not; the pose moves the points first. Counted exactly: fractions of all points.
TEST(FreeSpace, PointsInFrontOfWhatTheScanSawContradictIt)
{
  Cloud wall;
  for (double y = -2.0; y <= 2.0; y += 0.05)
    for (double z = -2.0; z <= 2.0; z += 0.05)
      wall.push_back(pcl::PointXYZ(10.0f, static_cast<float>(y), static_cast<float>(z)));
  const slam::FreeSpace seen(wall, Eigen::Vector3d::UnitZ());
  EXPECT_EQ(seen.conflicts(wall, Pose::Identity(), 0.1), 0.0);

  Cloud points;
  for (const Eigen::Vector3f& p : {Eigen::Vector3f(5.0f, 0.0f, 0.0f),  // in front: conflict
                                   Eigen::Vector3f(9.0f, 1.0f, 0.5f),  // in front: conflict
                                   Eigen::Vector3f(9.95f, 0.0f, 0.0f), // on it, within 0.1
                                   Eigen::Vector3f(15.0f, 0.0f, 0.0f), // behind it
                                   Eigen::Vector3f(-5.0f, 0.0f, 0.0f), // no beam returned
                                   Eigen::Vector3f(5.0f, 5.0f, 0.0f)}) // past its edge
    points.push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  EXPECT_DOUBLE_EQ(seen.conflicts(points, Pose::Identity(), 0.1), 2.0 / 6.0);
  EXPECT_DOUBLE_EQ(seen.conflicts(points, Pose::Identity(), 4.5), 1.0 / 6.0); // 5 m in front
  // 6 m further out: (-5, 0, 0) comes to (1, 0, 0), in front of the wall; the rest lie
  // behind it or beside it.
  Pose back = Pose::Identity();
  back(0, 3) = 6.0;
  EXPECT_DOUBLE_EQ(seen.conflicts(points, back, 0.1), 1.0 / 6.0);
  back(0, 3) = 16.0; // all behind it or beside it
  EXPECT_DOUBLE_EQ(seen.conflicts(points, back, 0.1), 0.0);
  // 180 degrees about z: only (-5, 0, 0) comes to face the wall, at (5, 0, 0).
  Pose turned = Pose::Identity();
  turned.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  EXPECT_DOUBLE_EQ(seen.conflicts(points, turned, 0.1), 1.0 / 6.0);
  EXPECT_EQ(seen.conflicts(Cloud(), Pose::Identity(), 0.1), 0.0);
}

// A wall along the scanner's view (y = 1, x from 1 to 20 m), its points 0.5 m apart as a
// reduced scan keeps them: a bin at a grazing angle holds one point from its far end, yet
// the beams did not pass the wall there. The same wall sampled between those points does
// not contradict it; the wall doubled 0.3 m nearer does, where the first one was seen.
TEST(FreeSpace, AWallSeenAtAGrazingAngleIsNotFreeSpaceInFrontOfItsPoints)
{
  const auto wallAt = [](double y, double first) {
    Cloud wall;
    for (double x = first; x <= 20.0; x += 0.5)
      wall.push_back(pcl::PointXYZ(static_cast<float>(x), static_cast<float>(y), 0.0f));
    return wall;
  };
  const slam::FreeSpace seen(wallAt(1.0, 1.0), Eigen::Vector3d::UnitZ());
  EXPECT_EQ(seen.conflicts(wallAt(1.0, 1.25), Pose::Identity(), 0.1), 0.0);
  EXPECT_GT(seen.conflicts(wallAt(0.7, 1.25), Pose::Identity(), 0.1), 0.5);
}

// A scan of the courtyard against itself: none at the true pose, and a station's scan
// put 4 m off (walls into the open yard) contradicts it far more than at its own pose.
// Bad settings throw.
TEST(FreeSpace, AWrongPoseContradictsTheScanAndBadSettingsThrow)
{
  const Cloud world = courtyard();
  const Pose a = station(0.0, -6.0, 2.0, 0.0), b = station(30.0 * kDeg, 3.0, -1.0, 0.0);
  const Cloud target = scanFrom(world, a, 25.0), source = scanFrom(world, b, 25.0);
  const slam::FreeSpace seen(target, Eigen::Vector3d::UnitZ());
  const Pose truth = a.inverse() * b;
  Pose off = truth;
  off(1, 3) += 4.0;
  const double right = seen.conflicts(source, truth, 0.3),
               wrong = seen.conflicts(source, off, 0.3);
  std::printf("courtyard: conflicts at the true pose %.3f, 4 m off %.3f\n", right, wrong);
  EXPECT_LT(right, 0.01);
  EXPECT_GT(wrong, 0.05);
  EXPECT_THROW(slam::FreeSpace(target, Eigen::Vector3d::Zero()), std::invalid_argument);
  EXPECT_THROW(seen.conflicts(source, truth, -0.1), std::invalid_argument);
  EXPECT_THROW(seen.conflicts(source, truth, std::nan("")), std::invalid_argument);
  for (double bin : {0.0, -1.0, 1e-9, std::nan("")})
    EXPECT_THROW(slam::FreeSpace(target, Eigen::Vector3d::UnitZ(), bin), std::invalid_argument);
}

} // namespace
