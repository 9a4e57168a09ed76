/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

namespace pcl_parallel {
namespace test {

/** n points, uniform in [-1, 1]^3 (fixed seed). */
inline pcl::PointCloud<pcl::PointXYZ>
uniformCloud(std::size_t n, std::uint32_t seed)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  pcl::PointCloud<pcl::PointXYZ> cloud;
  for (std::size_t i = 0; i < n; ++i)
    cloud.push_back(pcl::PointXYZ(u(rng), u(rng), u(rng)));
  return cloud;
}

/** n points in a few tight Gaussian clusters of very different density, plus outliers:
 *  closer to a laser scan's density than uniform noise. */
inline pcl::PointCloud<pcl::PointXYZ>
clusteredCloud(std::size_t n, std::uint32_t seed)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-5.0f, 5.0f);
  std::vector<pcl::PointXYZ> centres;
  for (int c = 0; c < 8; ++c)
    centres.emplace_back(u(rng), u(rng), u(rng));
  pcl::PointCloud<pcl::PointXYZ> cloud;
  for (std::size_t i = 0; i < n; ++i) {
    if (i % 50 == 0) {
      cloud.push_back(pcl::PointXYZ(u(rng), u(rng), u(rng)));
      continue;
    }
    const auto& c = centres[i % centres.size()];
    std::normal_distribution<float> g(0.0f, 0.01f * static_cast<float>(1 + i % 8));
    cloud.push_back(pcl::PointXYZ(c.x + g(rng), c.y + g(rng), c.z + g(rng)));
  }
  return cloud;
}

/** A copy of cloud with Gaussian noise of sigma on every coordinate (fixed seed). */
inline pcl::PointCloud<pcl::PointXYZ>
jittered(const pcl::PointCloud<pcl::PointXYZ>& cloud, float sigma, std::uint32_t seed)
{
  std::mt19937 rng(seed);
  std::normal_distribution<float> g(0.0f, sigma);
  pcl::PointCloud<pcl::PointXYZ> out;
  for (const auto& p : cloud)
    out.push_back(pcl::PointXYZ(p.x + g(rng), p.y + g(rng), p.z + g(rng)));
  return out;
}

/** Brute-force nearest neighbour: {index, squared distance}, index -1 if none within
 *  max_sqr (inclusive). Squared distance summed as the tree does: dx², dy², dz² in order. */
template <typename PointQ, typename PointT>
std::pair<int, float>
bruteNearest(const PointQ& q,
             const pcl::PointCloud<PointT>& cloud,
             float max_sqr = std::numeric_limits<float>::infinity())
{
  int best = -1;
  float best_d2 = std::numeric_limits<float>::infinity();
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const auto& p = cloud[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      continue;
    const float dx = q.x - p.x, dy = q.y - p.y, dz = q.z - p.z;
    const float d2 = dx * dx + dy * dy + dz * dz;
    if (d2 <= max_sqr && d2 < best_d2) {
      best_d2 = d2;
      best = static_cast<int>(i);
    }
  }
  return {best, best_d2};
}

/** All squared distances from q to the finite points of cloud, sorted ascending. */
template <typename PointQ, typename PointT>
std::vector<float>
bruteSortedDistances(const PointQ& q, const pcl::PointCloud<PointT>& cloud)
{
  std::vector<float> d;
  for (const auto& p : cloud) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      continue;
    const float dx = q.x - p.x, dy = q.y - p.y, dz = q.z - p.z;
    d.push_back(dx * dx + dy * dy + dz * dz);
  }
  std::sort(d.begin(), d.end());
  return d;
}

/** n points on the walls, floor and ceiling of a 4 x 3 x 2.5 room with a 0.8 m box on the
 *  floor, Gaussian noise of sigma (fixed seed): planes in three directions constrain all
 *  six degrees of freedom, and a new seed samples the same surfaces at other points. */
inline pcl::PointCloud<pcl::PointXYZ>
roomCloud(std::size_t n, std::uint32_t seed, float sigma = 0.0f)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> g(0.0f, sigma > 0 ? sigma : 1.0f);
  const float ext[3] = {4.0f, 3.0f, 2.5f};
  pcl::PointCloud<pcl::PointXYZ> cloud;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t face = i % 9;
    float p[3];
    if (face < 6) { // a wall
      for (int a = 0; a < 3; ++a)
        p[a] = u(rng) * ext[a];
      p[face / 2] = (face % 2) ? ext[face / 2] : 0.0f;
    }
    else { // one of three faces of the box at (1, 1, 0)
      for (int a = 0; a < 3; ++a)
        p[a] = (a == 0 ? 1.0f : a == 1 ? 1.0f : 0.0f) + 0.8f * u(rng);
      p[face - 6] = face == 8 ? 0.8f : 1.8f; // top, and the two sides facing the room
    }
    if (sigma > 0)
      for (float& c : p)
        c += g(rng);
    cloud.push_back(pcl::PointXYZ(p[0], p[1], p[2]));
  }
  return cloud;
}

} // namespace test
} // namespace pcl_parallel
