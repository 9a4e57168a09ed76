/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * A planar pose graph as g2o's text format writes it (g2o's types_slam2d: VERTEX_SE2 and
 * EDGE_SE2), for the 2D logs: the graph a run of ours built, read by g2o, by g2o_viewer
 * and by the other SLAM back ends that take the format.
 */
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace io {

/** One edge of an SE(2) pose graph: pose `to` seen from pose `from`, and how sure. */
struct G2oEdgeSe2 {
  std::size_t from = 0; ///< the vertex the measurement is taken in
  std::size_t to = 0;   ///< the vertex measured
  /** x_from⁻¹·x_to as a 4x4 pose (planar: a rotation about z). */
  Eigen::Matrix4d measurement = Eigen::Matrix4d::Identity();
  /** Inverse covariance over (dx, dy, dθ); g2o reads its upper triangle. */
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
};

/** The edge between poses `from` and `to` as the poses have it: x_from⁻¹·x_to. Throws
 *  std::out_of_range for an index beyond the poses. */
G2oEdgeSe2
g2oEdgeBetween(const std::vector<Eigen::Matrix4d>& poses,
               std::size_t from,
               std::size_t to,
               const Eigen::Matrix3d& information = Eigen::Matrix3d::Identity());

/** The planar part of a pose, (x, y, θ) with θ = atan2(R₁₀, R₀₀) in (-π, π]. */
Eigen::Vector3d
toSe2(const Eigen::Matrix4d& pose);

/** Writes "VERTEX_SE2 i x y θ" per pose (i from 0), then per edge "EDGE_SE2 from to dx dy
 *  dθ I11 I12 I13 I22 I23 I33" (the information's upper triangle, row by row), numbers in
 *  the shortest form that reads back exactly, atomically (writeStreamAtomically). Throws
 *  std::invalid_argument before writing anything for a pose or edge that is not finite,
 *  a rotation not about z (beyond kRigidMotionTolerance: a 3D pose has no SE(2) vertex),
 *  an edge index beyond the poses, or an information matrix that is not symmetric. */
void
writeG2oSe2(const std::string& path,
            const std::vector<Eigen::Matrix4d>& poses,
            const std::vector<G2oEdgeSe2>& edges);

} // namespace io
} // namespace pcl_parallel
