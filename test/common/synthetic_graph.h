/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Fixtures shared by the tests and the benchmark (which adds test/common to its include
 * path): pose graphs with exact correspondences, pose perturbations, and the iteration
 * count PCL keeps protected.
 */
#pragma once

#include <pcl/correspondence.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

namespace pcl_parallel {
namespace test {

/**
 * A graph with exact, noisy correspondences: for every link (i, j), `per_link` world
 * points around the two poses (uniform within +-spread of their mid-point) are seen by
 * both scans, in their own frames, with Gaussian noise `noise`; the link's pairs are
 * those points.
 */
struct SyntheticGraph {
  std::vector<Eigen::Matrix4d> truth;
  std::vector<pcl::PointCloud<pcl::PointXYZ>::Ptr> clouds;
  std::vector<std::tuple<std::uint32_t, std::uint32_t, pcl::CorrespondencesPtr>> links;
};

/** Draws from `rng`, so a caller can continue its own random sequence. */
template <typename Rng>
SyntheticGraph
makeGraph(const std::vector<Eigen::Matrix4d>& truth,
          const std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs,
          int per_link,
          double spread,
          double noise,
          Rng& rng)
{
  std::uniform_real_distribution<double> u(-spread, spread);
  std::normal_distribution<double> g(0.0, noise);
  SyntheticGraph sg;
  sg.truth = truth;
  for (std::size_t v = 0; v < truth.size(); ++v)
    sg.clouds.emplace_back(new pcl::PointCloud<pcl::PointXYZ>);
  auto see = [&](std::uint32_t v, const Eigen::Vector3d& w) {
    const Eigen::Matrix4d inv = truth[v].inverse();
    const Eigen::Vector3d p = inv.template topLeftCorner<3, 3>() * w +
                              inv.template topRightCorner<3, 1>() +
                              Eigen::Vector3d(g(rng), g(rng), g(rng));
    sg.clouds[v]->push_back(pcl::PointXYZ(
        static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
    return static_cast<int>(sg.clouds[v]->size() - 1);
  };
  for (const auto& [i, j] : pairs) {
    pcl::CorrespondencesPtr corrs(new pcl::Correspondences);
    const Eigen::Vector3d centre = 0.5 * (truth[i].template topRightCorner<3, 1>() +
                                          truth[j].template topRightCorner<3, 1>());
    for (int k = 0; k < per_link; ++k) {
      const Eigen::Vector3d w = centre + Eigen::Vector3d(u(rng), u(rng), u(rng));
      const int qi = see(i, w);
      const int qj = see(j, w);
      corrs->emplace_back(qi, qj, 0.0f);
    }
    sg.links.emplace_back(i, j, corrs);
  }
  return sg;
}

inline SyntheticGraph
makeGraph(const std::vector<Eigen::Matrix4d>& truth,
          const std::vector<std::pair<std::uint32_t, std::uint32_t>>& pairs,
          int per_link,
          double spread,
          double noise,
          std::uint32_t seed)
{
  std::mt19937 rng(seed);
  return makeGraph(truth, pairs, per_link, spread, noise, rng);
}

/** T rotated by exactly `angle` about a random axis and moved by exactly `dist`. */
inline Eigen::Matrix4d
perturb(const Eigen::Matrix4d& t, double angle, double dist, std::mt19937& rng)
{
  std::normal_distribution<double> g;
  const Eigen::Vector3d axis = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
  const Eigen::Vector3d dir = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
  Eigen::Matrix4d out = t;
  out.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(angle, axis).toRotationMatrix() * t.topLeftCorner<3, 3>();
  out.topRightCorner<3, 1>() += dist * dir;
  return out;
}

/** Reads the protected iteration counter of a PCL registration (PCL 1.13 has no getter):
 *  through a pointer to the base's member, so `r` need not be a Peek. */
template <typename Reg>
struct Peek : Reg {
  static int
  iterations(const Reg& r)
  {
    return r.*(&Peek::nr_iterations_);
  }
};

} // namespace test
} // namespace pcl_parallel
