/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The sparse solve of ParallelLUM's normal equations G X = B over the link blocks, and
 * the graph's connectivity. Non-template, compiled once in
 * src/registration/pose_graph_solver.cpp.
 */
#pragma once

#include <pcl_parallel/registration/lum_link.h>

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

namespace pcl_parallel {
namespace lum {

/**
 * \brief Assembles and solves the sparse normal equations G X = B over vertices
 * 1..n-1 (vertex 0 is the fixed reference) with Eigen's SimplicialLDLT in double
 * (paper Sec. III steps 3-4; the O(n^3) dense solve of PCL's LUM becomes a sparse
 * Cholesky whose cost follows the fill of the graph).
 *
 * Triplets are generated from the link blocks in link order, so G and B, and hence the
 * solution, do not depend on which thread computed which link. The symbolic analysis is
 * reused while the link structure stays the same.
 */
class PoseGraphSolver {
public:
  PoseGraphSolver();
  ~PoseGraphSolver();
  PoseGraphSolver(const PoseGraphSolver&) = delete;
  PoseGraphSolver&
  operator=(const PoseGraphSolver&) = delete;

  /** Solve for x, y and the yaw alone (the planar special case, Sec. VII): the updates'
   *  other three components are zero, G X = B reduced to its planar rows and columns. */
  void
  setPlanar(bool planar);

  /** Solves for the updates of all n vertices (delta[0] = 0). Returns false if the
   *  factorisation fails (e.g. a vertex without a valid link). */
  bool
  solve(std::size_t num_vertices,
        const std::vector<LinkBlock, Eigen::aligned_allocator<LinkBlock>>& links,
        std::vector<Vector6d, Eigen::aligned_allocator<Vector6d>>& delta);

  /** Marginal covariance of vertex v (1..n-1) from the last factorisation: the 6x6
   *  diagonal block of G^-1 (paper step 5, "update the covariances"; planar: zero outside
   *  the planar rows and columns). Zero for v = 0. */
  Matrix6d
  covariance(std::size_t v) const;

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/** Vertices not connected to vertex 0 through the given (source, target) links. */
std::vector<std::uint32_t>
unreachableFromZero(std::size_t num_vertices,
                    const std::vector<std::pair<std::uint32_t, std::uint32_t>>& links);

} // namespace lum
} // namespace pcl_parallel
