/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The relation-based metric of Kümmerle, Steder, Dornhege, Ruhnke, Grisetti, Stachniss and
 * Kleiner, "On measuring the accuracy of SLAM algorithms", Autonomous Robots 27(4), 2009:
 * instead of poses against a ground-truth trajectory, relative motions between pairs of
 * time stamps against motions measured by hand (the Freiburg benchmark's .relations
 * files). Per relation the error is δ ⊖ δ* (Eq. 1 there): the estimate's relative motion
 * δ = x_i⁻¹·x_j seen from the measured one, E = δ*⁻¹·δ; its translation |t(E)| and its
 * rotation angle(E) are summarised as the paper tabulates them: mean ± standard deviation
 * of the absolute and of the squared errors.
 */
#pragma once

#include <pcl_parallel/evaluation/pose_error.h>
#include <pcl_parallel/io/pose_files.h>

#include <Eigen/Core>

#include <cstddef>
#include <ostream>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace evaluation {

/** One line of a .relations file: the motion measured between the robot at two times. */
struct Relation {
  double t1 = 0.0; ///< the first time stamp (s)
  double t2 = 0.0; ///< the second time stamp (s)
  /** δ*: the pose at t2 in the frame of the pose at t1, p_1 = δ*·p_2. */
  Eigen::Matrix4d motion = Eigen::Matrix4d::Identity();
  std::size_t line = 0; ///< its line in the file (from 1)
};

/** Reads a Freiburg .relations file: per line "t1 t2 x y z roll pitch yaw" (seconds,
 *  metres, radians; R = Rz(yaw)·Ry(pitch)·Rx(roll), as cartographer's reader of these
 *  files), blank lines and lines starting with '#' skipped. Throws std::runtime_error
 *  "pcl_parallel::io: FILE:LINE: what" for a line without exactly 8 finite numbers, a
 *  file it cannot read, and a file without any relation. */
std::vector<Relation>
loadRelations(const std::string& path);

/** Mean and standard deviation of a list: the sample standard deviation (divided by
 *  n - 1), as cartographer's compute_relations_metrics prints the paper's "mean ± std";
 *  0 for fewer than two values. */
struct MeanStd {
  double mean = 0.0; ///< the mean
  double std = 0.0;  ///< the sample standard deviation
};

/** The MeanStd of `values` (both 0 for an empty list). */
MeanStd
meanStd(const std::vector<double>& values);

/** The metric over the relations whose two times both match a pose. */
struct RelationError {
  std::size_t relations = 0; ///< relations given
  std::size_t used = 0;      ///< relations whose t1 and t2 both matched a pose
  std::size_t unmatched = 0; ///< relations - used
  double max_diff = 0.0;     ///< the matching tolerance (s)
  /** Per used relation, in the relations' order: |t(E)| (m) and angle(E) (deg). */
  ///@{
  std::vector<double> translation_m, rotation_deg;
  ///@}
  /** The paper's table: absolute and squared errors, mean ± std. */
  ///@{
  MeanStd translation, translation_squared; ///< m, m²
  MeanStd rotation, rotation_squared;       ///< deg, deg²
  ///@}
};

/** The relation error of a trajectory (pose k taken at stamps[k], in any order): each
 *  relation's t1 and t2 matched to the nearest stamp, kept when both lie within max_diff
 *  seconds. Throws std::invalid_argument when stamps and poses differ in size or max_diff
 *  is negative or not a number. */
RelationError
relationError(const std::vector<double>& stamps,
              const Poses& poses,
              const std::vector<Relation>& relations,
              double max_diff = 0.01);

/** A trajectory file evaluated against a relations file (`pcl_pslam evaluate ESTIMATE
 *  --relations FILE`). */
struct RelationFileEvaluation {
  std::string estimate_path;  ///< ESTIMATE as given
  std::string relations_path; ///< FILE as given
  io::Trajectory estimate;    ///< as read
  RelationError errors;       ///< relationError's result
};

/** Reads the trajectory (io::loadTrajectory; it must have time stamps: TUM) and the
 *  relations, checks every pose (requireRigidMotions) and computes relationError. Throws
 *  std::runtime_error naming the file for a file it cannot read, a trajectory without
 *  time stamps, and where no relation matches. */
RelationFileEvaluation
evaluateRelationsFile(const std::string& estimate_path,
                      const std::string& relations_path,
                      double max_diff = 0.01,
                      double frames_unit = io::kFramesUnit);

/** The files, the matching, then the paper's table (mean and std per row). */
void
printRelationEvaluation(std::ostream& out, const RelationFileEvaluation& evaluation);

/** The evaluation as JSON text (`--json`), indented by `indent` spaces (-1: one line). */
std::string
toJson(const RelationFileEvaluation& evaluation, int indent = 2);

} // namespace evaluation
} // namespace pcl_parallel
