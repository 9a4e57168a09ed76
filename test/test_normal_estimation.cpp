/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * estimateNormals against pcl::NormalEstimation (same k, same viewpoint) and across
 * thread counts; estimateUnitNormals (pLUM's) on a sphere and a line.
 */
#include "random_clouds.h"
#include "test_data.h"

#include <pcl_parallel/io/stanford.h>
#include <pcl_parallel/normal_estimation.h>
#include <pcl_parallel/search/kdtree.h>

#include <pcl/features/normal_3d.h>

#include <Eigen/Geometry>

#include <cmath>
#include <cstring>
#include <gtest/gtest.h>
#include <random>

namespace {

// Same normals as PCL's NormalEstimation with setKSearch(10) (orientation towards the
// origin included) on the bunny: 99 % agree to 0.1 deg (PCL sums in float), 99.9 % to
// 5 deg; the rest are range-grid neighbourhoods whose 10th neighbour is a tie, resolved
// differently by FLANN and our tree.
TEST(EstimateNormals, MatchesPclNormalEstimation)
{
  PCL_PARALLEL_REQUIRE_DATA(f0, "stanford_bunny/bun000.ply");
  const auto cloud = pcl_parallel::io::loadStanfordScan(f0);
  pcl_parallel::search::KdTree<pcl::PointXYZ> tree;
  tree.setInputCloud(cloud);
  std::vector<float> ours;
  pcl_parallel::estimateNormals(tree.index(), 10, 0, ours);
  ASSERT_EQ(ours.size(), 3 * cloud->size());

  pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
  ne.setInputCloud(cloud);
  ne.setKSearch(10);
  pcl::PointCloud<pcl::Normal> ref;
  ne.compute(ref);
  std::size_t agree = 0, compared = 0, agree5 = 0;
  for (std::uint32_t pos = 0; pos < tree.index().size(); ++pos) {
    const auto& r = ref[tree.index().id(pos)];
    if (!std::isfinite(r.normal_x))
      continue;
    ++compared;
    const double dot = r.normal_x * ours[3 * pos] + r.normal_y * ours[3 * pos + 1] +
                       r.normal_z * ours[3 * pos + 2];
    if (dot > std::cos(0.1 * M_PI / 180.0))
      ++agree;
    if (dot > std::cos(5.0 * M_PI / 180.0))
      ++agree5;
  }
  EXPECT_EQ(compared, cloud->size());
  EXPECT_GT(static_cast<double>(agree), 0.99 * static_cast<double>(compared))
      << agree << " of " << compared;
  EXPECT_GT(static_cast<double>(agree5), 0.999 * static_cast<double>(compared))
      << agree5 << " of " << compared;
}

// Planes give their normal exactly; identical for 1, 2 and 4 threads; a tree with fewer
// than 3 points or coincident neighbours gives NaN.
TEST(EstimateNormals, PlanesThreadsAndDegenerateInput)
{
  const auto room = pcl_parallel::test::roomCloud(20000, 3).makeShared();
  pcl_parallel::search::KdTree<pcl::PointXYZ> tree;
  tree.setInputCloud(room);
  std::vector<float> n1, n2, n4;
  pcl_parallel::estimateNormals(tree.index(), 8, 1, n1);
  pcl_parallel::estimateNormals(tree.index(), 8, 2, n2);
  pcl_parallel::estimateNormals(tree.index(), 8, 4, n4);
  ASSERT_EQ(n1.size(), n2.size());
  EXPECT_EQ(0, std::memcmp(n1.data(), n2.data(), n1.size() * sizeof(float)));
  EXPECT_EQ(0, std::memcmp(n1.data(), n4.data(), n1.size() * sizeof(float)));
  // Points on the floor away from walls and box: normal (0, 0, 1) (towards the origin's
  // side: the origin lies on the floor's plane, so the sign is free; compare |n_z|).
  std::size_t floor = 0;
  for (std::uint32_t pos = 0; pos < tree.index().size(); ++pos) {
    const float* p = tree.index().point(pos);
    if (p[2] != 0.0f || p[0] < 2.4f || p[0] > 3.6f || p[1] < 0.4f || p[1] > 2.6f)
      continue;
    ++floor;
    EXPECT_NEAR(std::abs(n1[3 * pos + 2]), 1.0f, 1e-6f) << pos;
  }
  EXPECT_GT(floor, 100u);

  pcl::PointCloud<pcl::PointXYZ>::Ptr two(new pcl::PointCloud<pcl::PointXYZ>);
  two->push_back(pcl::PointXYZ(0, 0, 0));
  two->push_back(pcl::PointXYZ(1, 0, 0));
  tree.setInputCloud(two);
  pcl_parallel::estimateNormals(tree.index(), 10, 0, n1);
  ASSERT_EQ(n1.size(), 6u);
  for (float v : n1)
    EXPECT_TRUE(std::isnan(v));
  pcl::PointCloud<pcl::PointXYZ>::Ptr same(new pcl::PointCloud<pcl::PointXYZ>);
  for (int i = 0; i < 5; ++i)
    same->push_back(pcl::PointXYZ(1, 2, 3));
  tree.setInputCloud(same);
  pcl_parallel::estimateNormals(tree.index(), 10, 0, n1);
  for (float v : n1)
    EXPECT_TRUE(std::isnan(v));
}

// pLUM's unit normals: radial for points on a sphere; none for points on a line.
TEST(EstimateUnitNormals, RadialOnASphereNoneOnALine)
{
  std::vector<float> xyz;
  std::mt19937 rng(6);
  std::normal_distribution<float> g;
  for (int k = 0; k < 5000; ++k) {
    Eigen::Vector3f p(g(rng), g(rng), g(rng));
    p.normalize();
    xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
  }
  pcl_parallel::KdTreeIndex tree;
  tree.build(xyz.data(), 5000, 3);
  const auto normals = pcl_parallel::estimateUnitNormals(tree, 10, 2);
  ASSERT_EQ(normals.size(), tree.size());
  for (std::uint32_t pos = 0; pos < tree.size(); ++pos) {
    const Eigen::Vector3f p = Eigen::Vector3f::Map(tree.point(pos));
    EXPECT_GT(std::abs(normals[pos].dot(p)), 0.99f) << pos;
  }
  std::vector<float> line;
  for (int k = 0; k < 50; ++k)
    line.insert(line.end(), {0.1f * k, 0.2f * k, 0.0f});
  tree.build(line.data(), 50, 3);
  for (const Eigen::Vector3f& n : pcl_parallel::estimateUnitNormals(tree, 10, 1))
    EXPECT_EQ(n, Eigen::Vector3f::Zero());
}

// A 2D scan's normals lie in its plane, normal to the walls' lines: a square room's
// outline gives each wall's normal (none where the neighbours coincide); the 3D estimate
// of the same points is the plane's normal, useless to planar pICP.
TEST(EstimateUnitNormals, InThePlaneOfATwoDScan)
{
  std::vector<float> xyz;
  for (int k = 0; k < 200; ++k) {
    const float t = -4.0f + 0.04f * k;
    xyz.insert(xyz.end(), {t, -4.0f, 0.0f, 4.0f, t, 0.0f, -t, 4.0f, 0.0f, -4.0f, -t, 0.0f});
  }
  pcl_parallel::KdTreeIndex tree;
  tree.build(xyz.data(), xyz.size() / 3, 3);
  const Eigen::Vector3f up = Eigen::Vector3f::UnitZ();
  const auto in_plane = pcl_parallel::estimateUnitNormals(tree, 10, 2, up);
  const auto in_3d = pcl_parallel::estimateUnitNormals(tree, 10, 2);
  for (std::uint32_t pos = 0; pos < tree.size(); ++pos) {
    const Eigen::Vector3f p = Eigen::Vector3f::Map(tree.point(pos));
    if (std::abs(p.x()) > 3.5f && std::abs(p.y()) > 3.5f)
      continue; // a corner
    const Eigen::Vector3f wall =
        std::abs(p.x()) > std::abs(p.y()) ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitY();
    EXPECT_NEAR(std::abs(in_plane[pos].dot(wall)), 1.0f, 1e-5f) << pos;
    EXPECT_EQ(in_plane[pos].z(), 0.0f) << pos;
    EXPECT_EQ(in_3d[pos], Eigen::Vector3f::Zero()) << pos; // a line: no 3D plane
  }
  // The same about another axis: a wall in the x-z plane, up y.
  std::vector<float> turned;
  for (int k = 0; k < 100; ++k)
    turned.insert(turned.end(), {0.05f * k, 0.0f, 2.0f + 0.01f * k});
  tree.build(turned.data(), 100, 3);
  const Eigen::Vector3f normal = Eigen::Vector3f(-0.01f, 0.0f, 0.05f).normalized();
  for (const Eigen::Vector3f& n :
       pcl_parallel::estimateUnitNormals(tree, 10, 1, Eigen::Vector3f::UnitY()))
    EXPECT_NEAR(std::abs(n.dot(normal)), 1.0f, 1e-5f);
  std::vector<float> one_place(30, 1.0f); // ten points at one place: no line
  tree.build(one_place.data(), 10, 3);
  for (const Eigen::Vector3f& n : pcl_parallel::estimateUnitNormals(tree, 10, 1, up))
    EXPECT_EQ(n, Eigen::Vector3f::Zero());
}

} // namespace
