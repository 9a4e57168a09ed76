/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/pose_math.h>

#include <Eigen/Core>

#include <cstddef>
#include <vector>

namespace pcl_parallel {
namespace evaluation {

/** A trajectory: one 4x4 pose per frame, p_world = T·p. */
using Poses = std::vector<Eigen::Matrix4d>;

// The pose error and rotation angle live in pose_math.h; the evaluation API names them too.
using pcl_parallel::PoseError;
using pcl_parallel::poseError;
using pcl_parallel::rotationAngle;

/** Summary statistics of a list of errors, as evo reports them (evo/core/metrics.py,
 *  PE.get_statistic): rmse = sqrt(mean(e²)), mean, median (mean of the two middle values
 *  for an even count, as numpy), std (population, numpy's default), min, max. All zero for
 *  an empty list (count tells). */
struct Statistics {
  std::size_t count = 0; ///< number of errors summarised
  /** the statistic its name says, in the errors' unit */
  ///@{
  double rmse = 0.0, mean = 0.0, median = 0.0, std = 0.0, min = 0.0, max = 0.0;
  ///@}
};

/** The Statistics of \a values (evo's rmse, mean, median, std, min, max). */
Statistics
computeStatistics(std::vector<double> values);

/** Per-pose errors of a against b, index by index, without any alignment, from index
 *  \a first on (e.g. 1 to skip a pose fixed at the truth): angles in rad, distances in the
 *  poses' unit. Throws std::invalid_argument when a and b differ in size. */
struct PoseErrorSummary {
  /** Statistics of the rotation angles (rad) and of the position distances. */
  ///@{
  Statistics angle, distance;
  ///@}
};

/** Per-pose errors of \a a against \a b from index \a first on, summarised (see
 *  PoseErrorSummary). */
PoseErrorSummary
summarizePoseErrors(const Poses& a, const Poses& b, std::size_t first = 0);

} // namespace evaluation
} // namespace pcl_parallel
