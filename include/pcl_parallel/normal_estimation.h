/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/kdtree.h>

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace pcl_parallel {

/**
 * \brief Surface normals of every point of \a tree, in parallel: the eigenvector of the
 * smallest eigenvalue of the covariance of its \a k nearest neighbours (the point itself
 * included), oriented towards \a viewpoint (PCL's NormalEstimation with setKSearch(k) and
 * flipNormalTowardsViewpoint). \a normals receives 3 floats per tree position (leaf
 * order, as KdTreeIndex::point()); NaN where fewer than 3 neighbours exist or the
 * neighbourhood is a single point. Each normal depends on its neighbourhood alone, so the
 * result is identical for any thread count.
 */
void
estimateNormals(const KdTreeIndex& tree,
                unsigned k,
                unsigned num_threads,
                std::vector<float>& normals,
                const float viewpoint[3] = nullptr);

/** Unit surface normals of a tree's points, indexed by tree position (KdTreeIndex::
 *  point()): the direction of least variance of each point's k nearest neighbours
 *  (itself included), in the tree's frame, unoriented (pLUM's point-to-plane weights).
 *  Zero where the neighbourhood does not define a plane (fewer than 3 distinct points, or
 *  collinear ones). Parallel over points. */
std::vector<Eigen::Vector3f>
estimateUnitNormals(const KdTreeIndex& tree, std::size_t k, unsigned num_threads);

/** The same for a cloud whose points all lie in one plane (a 2D scan, z = 0): each normal
 *  lies in that plane (normal to \a plane_normal), along the neighbourhood's least
 *  variance within it, i.e. normal to a wall's line in the scan. Point-to-plane pairs of
 *  planar pICP and pLUM then measure the distance to that line (point-to-line ICP,
 *  Censi, ICRA 2008). Zero where the neighbours do not spread (fewer than 3 points, or
 *  all at one place). */
std::vector<Eigen::Vector3f>
estimateUnitNormals(const KdTreeIndex& tree,
                    std::size_t k,
                    unsigned num_threads,
                    const Eigen::Vector3f& plane_normal);

/** The normals estimateUnitNormals gives (within the plane normal to *plane_normal where
 *  given, else in space), at \a count query points (xyz, \a stride floats apart) over
 *  the tree's points: e.g. a scan's new points over the map they join. */
std::vector<Eigen::Vector3f>
estimateUnitNormalsAt(const KdTreeIndex& tree,
                      const float* queries,
                      std::size_t count,
                      std::size_t stride,
                      std::size_t k,
                      unsigned num_threads,
                      const Eigen::Vector3f* plane_normal = nullptr);

/**
 * \brief PCA of one neighbourhood, the step every normal estimate here shares: the
 * covariance of the \a count tree points at positions \a pos about their mean (summed in
 * double relative to \a origin, e.g. the query, so far-off coordinates lose no
 * precision), its eigenvalues (ascending) and the eigenvector of the smallest, the
 * normal. Callers judge the eigenvalues (is it a plane?). False for fewer than 3 points.
 */
bool
neighbourhoodNormal(const KdTreeIndex& tree,
                    const std::uint32_t* pos,
                    std::size_t count,
                    const float origin[3],
                    Eigen::Vector3d& normal,
                    Eigen::Vector3d& eigenvalues);

} // namespace pcl_parallel
