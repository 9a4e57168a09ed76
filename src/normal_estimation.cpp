/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/normal_estimation.h>
#include <pcl_parallel/parallel.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace pcl_parallel {

void
estimateNormals(const KdTreeIndex& tree,
                unsigned k,
                unsigned num_threads,
                std::vector<float>& normals,
                const float viewpoint[3])
{
  const std::size_t n = tree.size();
  normals.assign(3 * n, std::numeric_limits<float>::quiet_NaN());
  if (k < 3 || n < 3)
    return;
  const float vp[3] = {viewpoint ? viewpoint[0] : 0.0f,
                       viewpoint ? viewpoint[1] : 0.0f,
                       viewpoint ? viewpoint[2] : 0.0f};
  const unsigned threads = resolveNumberOfThreads(num_threads);
  parallelFor(n, threads, 512, [&](std::size_t first, std::size_t last) {
    std::vector<std::uint32_t> pos(k);
    std::vector<float> d2(k);
    for (std::size_t i = first; i < last; ++i) {
      const float* p = tree.point(static_cast<std::uint32_t>(i));
      const std::size_t found = tree.knn(p, k, pos.data(), d2.data());
      Eigen::Vector3d nrm, ev; // neighbourhoodNormal: false below 3 neighbours
      if (!neighbourhoodNormal(tree, pos.data(), found, p, nrm, ev) || !(ev.sum() > 0.0))
        continue; // all neighbours coincide
      // PCL's flipNormalTowardsViewpoint: n · (vp - p) >= 0.
      const double dot =
          nrm[0] * (vp[0] - p[0]) + nrm[1] * (vp[1] - p[1]) + nrm[2] * (vp[2] - p[2]);
      if (dot < 0)
        nrm = -nrm;
      float* out = &normals[3 * static_cast<std::size_t>(i)];
      for (int a = 0; a < 3; ++a)
        out[a] = static_cast<float>(nrm[a]);
    }
  });
}

std::vector<Eigen::Vector3f>
estimateUnitNormals(const KdTreeIndex& tree, std::size_t k, unsigned num_threads)
{
  const std::size_t n = tree.size();
  std::vector<Eigen::Vector3f> normals(n, Eigen::Vector3f::Zero());
  k = std::max<std::size_t>(k, 3);
  const unsigned threads = resolveNumberOfThreads(num_threads);
  // A scan's few thousand points over every thread.
  parallelFor(n, threads, 256, [&](std::size_t first, std::size_t last) {
    std::vector<std::uint32_t> pos(k);
    std::vector<float> sqr(k);
    for (std::size_t i = first; i < last; ++i) {
      const std::uint32_t p = static_cast<std::uint32_t>(i);
      const std::size_t got = tree.knn(tree.point(p), k, pos.data(), sqr.data());
      Eigen::Vector3d normal, ev;
      // A plane needs two clearly non-zero spreads; the normal's must be the smallest.
      if (!neighbourhoodNormal(tree, pos.data(), got, tree.point(p), normal, ev) ||
          !(ev(1) > 1e-6 * ev(2)))
        continue;
      normals[i] = normal.normalized().cast<float>();
    }
  });
  return normals;
}

bool
neighbourhoodNormal(const KdTreeIndex& tree,
                    const std::uint32_t* pos,
                    std::size_t count,
                    const float origin[3],
                    Eigen::Vector3d& normal,
                    Eigen::Vector3d& eigenvalues)
{
  if (count < 3)
    return false;
  const Eigen::Vector3f o = Eigen::Vector3f::Map(origin);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (std::size_t j = 0; j < count; ++j)
    mean += (Eigen::Vector3f::Map(tree.point(pos[j])) - o).cast<double>();
  mean /= static_cast<double>(count);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (std::size_t j = 0; j < count; ++j) {
    const Eigen::Vector3d d =
        (Eigen::Vector3f::Map(tree.point(pos[j])) - o).cast<double>() - mean;
    cov += d * d.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(cov);
  eigenvalues = eig.eigenvalues();
  normal = eig.eigenvectors().col(0);
  return normal.allFinite();
}

} // namespace pcl_parallel
