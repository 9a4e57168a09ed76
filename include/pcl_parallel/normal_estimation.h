/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/kdtree.h>

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

} // namespace pcl_parallel
