/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/evaluation/pose_error.h>

#include <Eigen/Core>

#include <string>

namespace pcl_parallel {
namespace evaluation {

/** How an estimate is aligned to the reference before absolute errors are taken:
 *  not at all, by the best rigid motion (evo_ape --align), or by the best similarity
 *  (evo_ape --align --correct_scale, for trajectories of unknown scale). */
enum class Alignment { None, SE3, Sim3 };

/** "none", "se3", "sim3" (what the command line takes). */
std::string
toString(Alignment a);

/** Parses "none", "se3" or "sim3"; throws std::invalid_argument otherwise. */
Alignment
alignmentFromString(const std::string& s);

/** x -> scale · rotation · x + translation. */
struct Similarity {
  /** Rotation R of the alignment. */
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  /** Translation t of the alignment. */
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  /** Scale c (1 for SE(3)). */
  double scale = 1.0;

  /** A pose of the estimate moved into the reference frame, as evo's PosePath3D.align
   *  does: its position scaled, then the rigid part applied on the left. */
  Eigen::Matrix4d
  apply(const Eigen::Matrix4d& pose) const;
};

/** The similarity (scale fixed to 1 unless with_scale) that minimises the mean squared
 *  distance sum |ref_i - (s·R·est_i + t)|² / n between the positions of two equally long
 *  pose lists: Umeyama (IEEE PAMI 13(4), 1991), Eq. 34-43, as evo's
 *  geometry.umeyama_alignment. Throws std::invalid_argument when the lists differ in size
 *  or are empty, and, as evo, when the positions are degenerate (fewer than two non-zero
 *  singular values of the cross-covariance: all positions on one line, so the rotation
 *  about that line is not determined), or, with scale, when the estimate's positions all
 *  coincide. */
Similarity
umeyamaAlignment(const Poses& estimate, const Poses& reference, bool with_scale);

/** The identity for Alignment::None, else umeyamaAlignment (Sim3: with scale). */
Similarity
alignTrajectory(const Poses& estimate, const Poses& reference, Alignment alignment);

} // namespace evaluation
} // namespace pcl_parallel
