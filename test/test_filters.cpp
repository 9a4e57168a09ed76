/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/filters/voxel_grid.h>

#include <pcl/common/transforms.h>
#include <pcl/filters/voxel_grid.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <gtest/gtest.h>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

Cloud
randomCloud(std::size_t n, float extent, unsigned seed)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-extent, extent);
  Cloud c;
  for (std::size_t i = 0; i < n; ++i)
    c.push_back(pcl::PointXYZ(u(rng), u(rng), 0.1f * u(rng)));
  return c;
}

std::vector<std::tuple<float, float, float>>
sorted(const Cloud& c)
{
  std::vector<std::tuple<float, float, float>> v;
  for (const auto& p : c)
    v.emplace_back(p.x, p.y, p.z);
  std::sort(v.begin(), v.end());
  return v;
}

// The same centroids as pcl::VoxelGrid where VoxelGrid works (it sums in float).
TEST(VoxelCentroid, MatchesPclVoxelGrid)
{
  const Cloud cloud = randomCloud(50000, 5.0f, 1);
  const auto ours = pcl_parallel::filters::voxelCentroid(cloud, 0.25);
  Cloud pcl_out;
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  grid.setInputCloud(cloud.makeShared());
  grid.setLeafSize(0.25f, 0.25f, 0.25f);
  grid.filter(pcl_out);
  ASSERT_EQ(ours->size(), pcl_out.size());
  const auto a = sorted(*ours), b = sorted(pcl_out);
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_NEAR(std::get<0>(a[i]), std::get<0>(b[i]), 1e-5);
    EXPECT_NEAR(std::get<1>(a[i]), std::get<1>(b[i]), 1e-5);
    EXPECT_NEAR(std::get<2>(a[i]), std::get<2>(b[i]), 1e-5);
  }
}

// Every output point is the mean of the input points of its voxel (brute force).
TEST(VoxelCentroid, CentroidOfEachVoxel)
{
  const Cloud cloud = randomCloud(2000, 2.0f, 2);
  const double v = 0.5;
  const auto out = pcl_parallel::filters::voxelCentroid(cloud, v);
  std::size_t total = 0;
  for (const auto& q : *out) {
    const auto key = [&](const pcl::PointXYZ& p) {
      return std::make_tuple(std::floor(p.x / v), std::floor(p.y / v), std::floor(p.z / v));
    };
    double sx = 0, sy = 0, sz = 0;
    int count = 0;
    for (const auto& p : cloud)
      if (key(p) == key(q))
        sx += p.x, sy += p.y, sz += p.z, ++count;
    ASSERT_GT(count, 0);
    total += count;
    EXPECT_NEAR(q.x, sx / count, 1e-6);
    EXPECT_NEAR(q.y, sy / count, 1e-6);
    EXPECT_NEAR(q.z, sz / count, 1e-6);
  }
  EXPECT_EQ(total, cloud.size()); // the voxels partition the cloud
}

// VoxelGrid gives up beyond 2^31 voxels in the bounding box; we reduce.
// Brute force: centroids in (x, y, z) key order, each summed in double in input order.
// Both the packed 64-bit keys and the wide ones (more than 2^21 voxels along an axis, here
// 2e7 at 1 mm) must give exactly these, in this order.
TEST(VoxelCentroid, KeyOrderAndCentroidsMatchBruteForce)
{
  // Small and large clouds (the large ones take the parallel blocks of the key packing, the
  // radix passes and the runs), with non-finite points between the blocks; extent 1e4 at
  // 1 mm needs more than 64 key bits (two sorts).
  for (const auto& [size, extent] :
       {std::pair<int, float>{5000, 5.0f}, {5000, 1e4f}, {120000, 5.0f}, {120000, 1e4f}}) {
    SCOPED_TRACE(std::to_string(size) + " points, extent " + std::to_string(extent));
    Cloud cloud = randomCloud(size, extent, 6);
    for (int i = 0; i < 2000; ++i) // many points per voxel too
      cloud.push_back(cloud[i % 50]);
    for (std::size_t i = 7; i < cloud.size(); i += cloud.size() / 5)
      cloud[i].y = std::numeric_limits<float>::quiet_NaN();
    const double voxel = extent > 100.0f ? 1e-3 : 0.5;
    std::map<std::array<std::int64_t, 3>, std::array<double, 4>> voxels;
    for (const auto& p : cloud) {
      if (!std::isfinite(p.y))
        continue;
      auto& v = voxels[{static_cast<std::int64_t>(std::floor(p.x / voxel)),
                        static_cast<std::int64_t>(std::floor(p.y / voxel)),
                        static_cast<std::int64_t>(std::floor(p.z / voxel))}];
      v[0] += p.x, v[1] += p.y, v[2] += p.z, v[3] += 1.0;
    }
    for (const unsigned threads : {1u, 3u}) { // serial, and uneven parallel blocks
      const auto out = pcl_parallel::filters::voxelCentroid(cloud, voxel, threads);
      ASSERT_EQ(out->size(), voxels.size()) << threads << " threads";
      std::size_t i = 0;
      for (const auto& [key, v] : voxels) {
        EXPECT_EQ((*out)[i].x, static_cast<float>(v[0] / v[3])) << i;
        EXPECT_EQ((*out)[i].y, static_cast<float>(v[1] / v[3])) << i;
        EXPECT_EQ((*out)[i].z, static_cast<float>(v[2] / v[3])) << i;
        ++i;
      }
    }
  }
}

TEST(VoxelCentroid, LargeExtentStillReduced)
{
  Cloud cloud = randomCloud(20000, 1.0f, 3);
  cloud.push_back(pcl::PointXYZ(5000.0f, -5000.0f, 300.0f)); // one far return
  const auto out = pcl_parallel::filters::voxelCentroid(cloud, 0.1);
  EXPECT_LT(out->size(), 20000u / 2);
  EXPECT_GT(out->size(), 100u);
  EXPECT_EQ(out->back().x, 5000.0f);
}

TEST(VoxelCentroid, DropsNonFiniteAndIsDense)
{
  Cloud cloud = randomCloud(100, 1.0f, 4);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cloud.push_back(pcl::PointXYZ(nan, 0, 0));
  cloud.push_back(pcl::PointXYZ(0, std::numeric_limits<float>::infinity(), 0));
  for (double v : {0.0, 0.3}) {
    const auto out = pcl_parallel::filters::voxelCentroid(cloud, v);
    EXPECT_TRUE(out->is_dense);
    for (const auto& p : *out)
      EXPECT_TRUE(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
  }
  EXPECT_EQ(pcl_parallel::filters::voxelCentroid(cloud, 0.0)->size(), 100u);
  EXPECT_TRUE(pcl_parallel::filters::voxelCentroid(Cloud(), 0.1)->empty());
}

TEST(VoxelCentroid, TooFarFromOriginThrows)
{
  Cloud cloud;
  cloud.push_back(pcl::PointXYZ(1e9f, 0, 0));
  EXPECT_THROW(pcl_parallel::filters::voxelCentroid(cloud, 1e-3), std::invalid_argument);
}

TEST(VoxelCentroid, SameForAnyThreadCount)
{
  const Cloud cloud = randomCloud(100000, 20.0f, 5);
  const auto one = pcl_parallel::filters::voxelCentroid(cloud, 0.2, 1);
  for (unsigned t : {2u, 3u, 4u, 16u}) { // 16: more blocks than this machine has cores
    const auto many = pcl_parallel::filters::voxelCentroid(cloud, 0.2, t);
    ASSERT_EQ(one->size(), many->size());
    for (std::size_t i = 0; i < one->size(); ++i) {
      EXPECT_EQ((*one)[i].x, (*many)[i].x);
      EXPECT_EQ((*one)[i].y, (*many)[i].y);
      EXPECT_EQ((*one)[i].z, (*many)[i].z);
    }
  }
}

// Brute force: per voxel, in key order, the input point (and its index) nearest the voxel's
// centroid (summed in double in input order), the first of equally near ones; for the serial
// path and the parallel blocks, with non-finite points and many points per voxel.
TEST(VoxelNearestToCentroid, MatchesBruteForce)
{
  for (const int size : {5000, 120000}) {
    SCOPED_TRACE(std::to_string(size) + " points");
    Cloud cloud = randomCloud(size, 5.0f, 7);
    for (int i = 0; i < 2000; ++i) // duplicates: ties go to the first
      cloud.push_back(cloud[i % 50]);
    for (std::size_t i = 7; i < cloud.size(); i += cloud.size() / 5)
      cloud[i].z = std::numeric_limits<float>::quiet_NaN();
    const double voxel = 0.5;
    std::map<std::array<std::int64_t, 3>, std::vector<std::size_t>> voxels;
    for (std::size_t i = 0; i < cloud.size(); ++i)
      if (std::isfinite(cloud[i].z))
        voxels[{static_cast<std::int64_t>(std::floor(cloud[i].x / voxel)),
                static_cast<std::int64_t>(std::floor(cloud[i].y / voxel)),
                static_cast<std::int64_t>(std::floor(cloud[i].z / voxel))}]
            .push_back(i);
    std::vector<std::size_t> expected;
    for (const auto& [key, members] : voxels) {
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (const std::size_t i : members)
        c += cloud[i].getVector3fMap().cast<double>();
      c /= static_cast<double>(members.size());
      std::size_t best = members.front();
      for (const std::size_t i : members)
        if ((cloud[i].getVector3fMap().cast<double>() - c).squaredNorm() <
            (cloud[best].getVector3fMap().cast<double>() - c).squaredNorm())
          best = i;
      expected.push_back(best);
    }
    for (const unsigned threads : {1u, 3u}) {
      const auto out = pcl_parallel::filters::voxelNearestToCentroid(cloud, voxel, threads);
      ASSERT_EQ(out->size(), expected.size()) << threads << " threads";
      for (std::size_t v = 0; v < expected.size(); ++v) {
        EXPECT_EQ((*out)[v].x, cloud[expected[v]].x) << v;
        EXPECT_EQ((*out)[v].y, cloud[expected[v]].y) << v;
        EXPECT_EQ((*out)[v].z, cloud[expected[v]].z) << v;
      }
      const std::vector<std::uint32_t> kept =
          pcl_parallel::filters::voxelNearestToCentroidIndices(cloud, voxel, threads);
      ASSERT_EQ(kept.size(), expected.size()) << threads << " threads";
      for (std::size_t v = 0; v < expected.size(); ++v)
        EXPECT_EQ(kept[v], expected[v]) << v;
    }
  }
}

// What it is for: on a pole and a wall corner seen from one side, every sampled point lies
// on the surface, where the voxels' centroids sit up to 1.5 cm inside the pole or off the
// corner's faces (a sample of centroids fails the first check).
TEST(VoxelNearestToCentroid, KeepsPointsOnCurvedSurfacesAndCorners)
{
  std::mt19937 rng(8);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  Cloud cloud;
  const float radius = 0.15f; // a pole at (3, 0), the half facing the scanner at the origin
  for (int i = 0; i < 20000; ++i) {
    const float a = static_cast<float>(M_PI) * (0.5f + u(rng)), z = 2.0f * u(rng);
    cloud.push_back(pcl::PointXYZ(3.0f + radius * std::cos(a), radius * std::sin(a), z));
  }
  for (int i = 0; i < 20000; ++i) { // a corner: faces x = 5 (1 < y < 3) and y = 3 (x < 5)
    const float s = 2.0f * u(rng), z = 2.0f * u(rng);
    cloud.push_back(i % 2 ? pcl::PointXYZ(5.0f, 3.0f - s, z)
                          : pcl::PointXYZ(5.0f - s, 3.0f, z));
  }
  const auto off_surface = [&](const pcl::PointXYZ& p) {
    if (p.y < 0.5f)
      return std::abs(std::hypot(p.x - 3.0f, p.y) - radius);
    return std::min(std::abs(p.x - 5.0f), std::abs(p.y - 3.0f));
  };
  const auto samples = pcl_parallel::filters::voxelNearestToCentroid(cloud, 0.25);
  const auto centroids = pcl_parallel::filters::voxelCentroid(cloud, 0.25);
  float worst_sample = 0.0f, worst_centroid = 0.0f;
  for (const auto& p : *samples)
    worst_sample = std::max(worst_sample, off_surface(p));
  for (const auto& p : *centroids)
    worst_centroid = std::max(worst_centroid, off_surface(p));
  EXPECT_LT(worst_sample, 1e-5f);
  EXPECT_GT(worst_centroid, 0.01f); // the geometry does tell the two apart
}

TEST(VoxelNearestToCentroid, DropsNonFiniteAndKeepsAllWithoutAVoxel)
{
  Cloud cloud = randomCloud(100, 1.0f, 9);
  cloud.push_back(pcl::PointXYZ(std::numeric_limits<float>::quiet_NaN(), 0, 0));
  EXPECT_EQ(pcl_parallel::filters::voxelNearestToCentroid(cloud, 0.0)->size(), 100u);
  EXPECT_EQ(pcl_parallel::filters::voxelNearestToCentroidIndices(cloud, 0.0).size(), 100u);
  const auto out = pcl_parallel::filters::voxelNearestToCentroid(cloud, 0.3);
  EXPECT_EQ(out->size(), pcl_parallel::filters::voxelCentroid(cloud, 0.3)->size());
  EXPECT_TRUE(out->is_dense);
  EXPECT_TRUE(pcl_parallel::filters::voxelNearestToCentroid(Cloud(), 0.1)->empty());
  Cloud far;
  far.push_back(pcl::PointXYZ(1e9f, 0, 0));
  EXPECT_THROW(pcl_parallel::filters::voxelNearestToCentroid(far, 1e-3), std::invalid_argument);
}

} // namespace

namespace {

// Scans added one by one give what voxelCentroid gives for them moved and concatenated:
// the same centroids, order and bits, for any thread count, also when grouped ahead.
TEST(VoxelCentroidMap, EqualsVoxelCentroidOfTheConcatenation)
{
  std::vector<Cloud> scans;
  std::vector<Eigen::Matrix4d> poses;
  Cloud all;
  for (unsigned k = 0; k < 4; ++k) {
    scans.push_back(randomCloud(30000, 8.0f, 10 + k));
    scans.back().push_back(pcl::PointXYZ(std::numeric_limits<float>::quiet_NaN(), 0, 0));
    Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
    pose.topLeftCorner<3, 3>() =
        Eigen::AngleAxisd(0.3 * k, Eigen::Vector3d(0.1, 0.2, 1.0).normalized()).matrix();
    pose.topRightCorner<3, 1>() = Eigen::Vector3d(1.5 * k, -0.7 * k, 0.1 * k);
    poses.push_back(pose);
    Cloud moved;
    pcl::transformPointCloud(scans.back(), moved, pose);
    all += moved;
  }
  const auto expected = pcl_parallel::filters::voxelCentroid(all, 0.25, 1);
  ASSERT_GT(expected->size(), 10000u); // centroids() sorts and merges in parallel
  for (unsigned t : {1u, 2u, 3u, 4u}) {
    pcl_parallel::filters::VoxelCentroidMap map(0.25, t);
    if (t == 3) { // grouped ahead, all at once on one thread each, added in order
      std::vector<pcl_parallel::filters::VoxelCentroidMap::Grouped> grouped(scans.size());
#pragma omp parallel for num_threads(4)
      for (std::int64_t k = 0; k < static_cast<std::int64_t>(scans.size()); ++k)
        grouped[k] = map.group(scans[k], poses[k], 1);
      for (auto& g : grouped)
        map.add(std::move(g));
    }
    else
      for (std::size_t k = 0; k < scans.size(); ++k)
        map.add(scans[k], poses[k]);
    EXPECT_EQ(map.size(), expected->size());
    const auto got = map.centroids();
    ASSERT_EQ(got->size(), expected->size()) << t;
    for (std::size_t i = 0; i < got->size(); ++i)
      ASSERT_EQ((*got)[i].getVector3fMap(), (*expected)[i].getVector3fMap()) << t << " " << i;
  }
  EXPECT_THROW(pcl_parallel::filters::VoxelCentroidMap(0.0), std::invalid_argument);
  pcl_parallel::filters::VoxelCentroidMap tiny(1e-3);
  EXPECT_THROW(
      tiny.add(pcl_parallel::filters::VoxelCentroidMap(0.25).group(scans[0], poses[0], 1)),
      std::invalid_argument);
  Cloud far;
  far.push_back(pcl::PointXYZ(1e9f, 0, 0));
  EXPECT_THROW(tiny.add(far), std::invalid_argument);
}

} // namespace
