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

namespace {

/** The scatter matrix of the `count` tree points at `pos` about their mean, summed in
 *  double relative to `origin`. */
Eigen::Matrix3d
neighbourhoodScatter(const KdTreeIndex& tree,
                     const std::uint32_t* pos,
                     std::size_t count,
                     const float origin[3])
{
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
  return cov;
}

/** The normal by `normal(query, neighbours, count)` over the k tree points nearest each of
 *  `count` queries (`query(i)`: xyz); a scan's few thousand points over every thread. */
template <typename QueryOf, typename NormalOf>
std::vector<Eigen::Vector3f>
unitNormals(const KdTreeIndex& tree,
            std::size_t count,
            const QueryOf& query,
            std::size_t k,
            unsigned num_threads,
            const NormalOf& normal)
{
  std::vector<Eigen::Vector3f> normals(count, Eigen::Vector3f::Zero());
  k = std::max<std::size_t>(k, 3);
  parallelFor(count,
              resolveNumberOfThreads(num_threads),
              256,
              [&](std::size_t first, std::size_t last) {
                std::vector<std::uint32_t> pos(k);
                std::vector<float> sqr(k);
                for (std::size_t i = first; i < last; ++i) {
                  const float* p = query(i);
                  normals[i] = normal(p, pos.data(), tree.knn(p, k, pos.data(), sqr.data()));
                }
              });
  return normals;
}

/** A neighbourhood's plane normal; zero where it does not define a plane. */
struct SpatialNormal {
  const KdTreeIndex& tree;
  Eigen::Vector3f
  operator()(const float* p, const std::uint32_t* pos, std::size_t got) const
  {
    Eigen::Vector3d normal, ev;
    // A plane needs two clearly non-zero spreads; the normal's must be the smallest.
    if (!neighbourhoodNormal(tree, pos, got, p, normal, ev) || !(ev(1) > 1e-6 * ev(2)))
      return Eigen::Vector3f::Zero();
    return normal.normalized().cast<float>();
  }
};

/** A neighbourhood's line normal within a plane; zero where the points do not spread. */
struct InPlaneNormal {
  InPlaneNormal(const KdTreeIndex& tree, const Eigen::Vector3f& plane_normal)
      : tree(tree)
  {
    // An orthonormal basis (e0, e1) of the plane: the scatter within it is 2x2.
    const Eigen::Vector3d u = plane_normal.cast<double>().normalized();
    const Eigen::Vector3d e0 = u.unitOrthogonal(), e1 = u.cross(e0);
    basis << e0, e1;
  }
  Eigen::Vector3f
  operator()(const float* p, const std::uint32_t* pos, std::size_t got) const
  {
    if (got < 3)
      return Eigen::Vector3f::Zero();
    const Eigen::Matrix2d scatter =
        basis.transpose() * neighbourhoodScatter(tree, pos, got, p) * basis;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig;
    eig.computeDirect(scatter);
    // The line needs a spread along it (1e-12 m²: points not all at one place).
    if (!(eig.eigenvalues()(1) > 1e-12))
      return Eigen::Vector3f::Zero();
    const Eigen::Vector3d normal = basis * eig.eigenvectors().col(0);
    if (!normal.allFinite())
      return Eigen::Vector3f::Zero();
    return normal.normalized().cast<float>();
  }
  const KdTreeIndex& tree;
  Eigen::Matrix<double, 3, 2> basis;
};

} // namespace

std::vector<Eigen::Vector3f>
estimateUnitNormals(const KdTreeIndex& tree, std::size_t k, unsigned num_threads)
{
  const auto own = [&](std::size_t i) { return tree.point(static_cast<std::uint32_t>(i)); };
  return unitNormals(tree, tree.size(), own, k, num_threads, SpatialNormal{tree});
}

std::vector<Eigen::Vector3f>
estimateUnitNormals(const KdTreeIndex& tree,
                    std::size_t k,
                    unsigned num_threads,
                    const Eigen::Vector3f& plane_normal)
{
  const auto own = [&](std::size_t i) { return tree.point(static_cast<std::uint32_t>(i)); };
  return unitNormals(tree, tree.size(), own, k, num_threads, InPlaneNormal(tree, plane_normal));
}

std::vector<Eigen::Vector3f>
estimateUnitNormalsAt(const KdTreeIndex& tree,
                      const float* queries,
                      std::size_t count,
                      std::size_t stride,
                      std::size_t k,
                      unsigned num_threads,
                      const Eigen::Vector3f* plane_normal)
{
  const auto at = [&](std::size_t i) { return queries + i * stride; };
  if (plane_normal)
    return unitNormals(tree, count, at, k, num_threads, InPlaneNormal(tree, *plane_normal));
  return unitNormals(tree, count, at, k, num_threads, SpatialNormal{tree});
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
  const Eigen::Matrix3d cov = neighbourhoodScatter(tree, pos, count, origin);
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(cov);
  eigenvalues = eig.eigenvalues();
  normal = eig.eigenvectors().col(0);
  return normal.allFinite();
}

} // namespace pcl_parallel
