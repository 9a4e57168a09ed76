/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/evaluation/trajectory_error.h>
#include <pcl_parallel/io/pose_files.h>

#include <Eigen/LU> // determinant

#include <cmath>
#include <limits>
#include <stdexcept>

namespace pcl_parallel {
namespace evaluation {

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

void
requireSameSize(const Poses& estimate, const Poses& reference, const char* what)
{
  if (estimate.size() != reference.size())
    throw std::invalid_argument(std::string("pcl_parallel::evaluation::") + what +
                                ": the estimate has " + std::to_string(estimate.size()) +
                                " poses, the reference " + std::to_string(reference.size()));
}

/** a⁻¹·b for rigid motions. */
Eigen::Matrix4d
relative(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b)
{
  Eigen::Matrix4d inv = Eigen::Matrix4d::Identity();
  inv.topLeftCorner<3, 3>() = a.topLeftCorner<3, 3>().transpose();
  inv.topRightCorner<3, 1>() = -(inv.topLeftCorner<3, 3>() * a.topRightCorner<3, 1>());
  return inv * b;
}

} // namespace

std::vector<double>
pathDistances(const Poses& poses)
{
  std::vector<double> dist(poses.empty() ? 0 : 1, 0.0);
  for (std::size_t i = 1; i < poses.size(); ++i)
    dist.push_back(
        dist.back() +
        (poses[i].topRightCorner<3, 1>() - poses[i - 1].topRightCorner<3, 1>()).norm());
  return dist;
}

AbsoluteError
absoluteTrajectoryError(const Poses& estimate, const Poses& reference, Alignment alignment)
{
  requireSameSize(estimate, reference, "absoluteTrajectoryError");
  AbsoluteError ate;
  ate.alignment = alignment;
  ate.similarity = alignTrajectory(estimate, reference, alignment);
  std::vector<double> trans, rot;
  for (std::size_t i = 0; i < estimate.size(); ++i) {
    const Eigen::Matrix4d est = ate.similarity.apply(estimate[i]);
    trans.push_back((est.topRightCorner<3, 1>() - reference[i].topRightCorner<3, 1>()).norm());
    rot.push_back(kRadToDeg * rotationAngle(relative(est, reference[i]).topLeftCorner<3, 3>()));
  }
  ate.translation = computeStatistics(std::move(trans));
  ate.rotation_deg = computeStatistics(std::move(rot));
  return ate;
}

std::vector<double>
kittiDefaultLengths()
{
  return {100, 200, 300, 400, 500, 600, 700, 800};
}

std::vector<double>
kittiLengthsFor(const Poses& reference)
{
  const std::vector<double> dist = pathDistances(reference);
  const double total = dist.empty() ? 0.0 : dist.back();
  if (total > 800.0)
    return kittiDefaultLengths();
  std::vector<double> lengths;
  if (total > 0.0)
    for (int k = 1; k <= 8; ++k)
      lengths.push_back(0.1 * k * total);
  return lengths;
}

KittiRelativeError
kittiRelativeError(const Poses& estimate,
                   const Poses& reference,
                   std::vector<double> lengths,
                   std::size_t step)
{
  requireSameSize(estimate, reference, "kittiRelativeError");
  if (step == 0)
    throw std::invalid_argument("pcl_parallel::evaluation::kittiRelativeError: step 0");
  KittiRelativeError out;
  out.lengths = lengths.empty() ? kittiLengthsFor(reference) : std::move(lengths);
  out.step = step;
  const std::vector<double> dist = pathDistances(reference); // along the ground truth
  for (std::size_t first = 0; first < reference.size(); first += step) {
    for (const double len : out.lengths) {
      // lastFrameFromSegmentLength: the first frame more than len further along.
      std::size_t last = first;
      while (last < dist.size() && !(dist[last] > dist[first] + len))
        ++last;
      if (last == dist.size())
        continue;
      const Eigen::Matrix4d error = relative(relative(estimate[first], estimate[last]),
                                             relative(reference[first], reference[last]));
      KittiSegment s;
      s.first_frame = first;
      s.last_frame = last;
      s.length = len;
      s.translation = error.topRightCorner<3, 1>().norm() / len;
      s.rotation = rotationAngle(error.topLeftCorner<3, 3>()) / len;
      out.segments.push_back(s);
    }
  }
  for (const double len : out.lengths) {
    KittiLengthError e;
    e.length = len;
    for (const KittiSegment& s : out.segments)
      if (s.length == len) {
        ++e.segments;
        e.translation_percent += s.translation;
        e.rotation_deg_per_m += s.rotation;
      }
    if (e.segments > 0) {
      e.translation_percent *= 100.0 / static_cast<double>(e.segments);
      e.rotation_deg_per_m *= kRadToDeg / static_cast<double>(e.segments);
    }
    out.per_length.push_back(e);
  }
  for (const KittiSegment& s : out.segments) { // getStats: the mean over every segment
    out.translation_percent += s.translation;
    out.rotation_deg_per_m += s.rotation;
  }
  if (out.valid()) {
    out.translation_percent *= 100.0 / static_cast<double>(out.segments.size());
    out.rotation_deg_per_m *= kRadToDeg / static_cast<double>(out.segments.size());
  }
  return out;
}

FrameRelativeError
frameRelativeError(const Poses& estimate, const Poses& reference, std::size_t delta)
{
  requireSameSize(estimate, reference, "frameRelativeError");
  if (delta == 0)
    throw std::invalid_argument("pcl_parallel::evaluation::frameRelativeError: delta 0");
  FrameRelativeError out;
  out.delta = delta;
  std::vector<double> trans, rot, point;
  for (std::size_t i = 0; i + delta < estimate.size(); i += delta) {
    const std::size_t j = i + delta;
    // evo's rpe_base: E = Q_rel⁻¹ · P_rel (Q reference, P estimate).
    const Eigen::Matrix4d e =
        relative(relative(reference[i], reference[j]), relative(estimate[i], estimate[j]));
    trans.push_back(e.topRightCorner<3, 1>().norm());
    rot.push_back(kRadToDeg * rotationAngle(e.topLeftCorner<3, 3>()));
    const double ref_d =
        (reference[i].topRightCorner<3, 1>() - reference[j].topRightCorner<3, 1>()).norm();
    const double est_d =
        (estimate[i].topRightCorner<3, 1>() - estimate[j].topRightCorner<3, 1>()).norm();
    point.push_back(std::abs(ref_d - est_d));
  }
  out.translation = computeStatistics(std::move(trans));
  out.rotation_deg = computeStatistics(std::move(rot));
  out.point_distance = computeStatistics(std::move(point));
  return out;
}

std::vector<std::pair<std::size_t, std::size_t>>
associateByTimestamp(const std::vector<double>& estimate_stamps,
                     const std::vector<double>& reference_stamps,
                     double max_diff)
{
  // evo: associate_trajectories(ref, est) walks the shorter (the estimate on a tie).
  const bool est_longer = estimate_stamps.size() > reference_stamps.size();
  const std::vector<double>& shorter = est_longer ? reference_stamps : estimate_stamps;
  const std::vector<double>& longer = est_longer ? estimate_stamps : reference_stamps;
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t i = 0; i < shorter.size(); ++i) {
    std::size_t best = 0;
    double best_diff = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < longer.size(); ++j) { // np.argmin: the first of equal ones
      const double diff = std::abs(longer[j] - shorter[i]);
      if (diff < best_diff) {
        best_diff = diff;
        best = j;
      }
    }
    if (best_diff <= max_diff)
      pairs.emplace_back(est_longer ? best : i, est_longer ? i : best);
  }
  return pairs;
}

void
requireRigidMotions(const Poses& poses, const std::string& name)
{
  for (std::size_t i = 0; i < poses.size(); ++i)
    if (const std::string problem = io::poseProblem(poses[i]); !problem.empty())
      throw std::invalid_argument(name + ": pose " + std::to_string(i + 1) + " " + problem);
}

TrajectoryEvaluation
evaluateTrajectory(const Poses& estimate,
                   const Poses& reference,
                   const EvaluationOptions& options)
{
  requireSameSize(estimate, reference, "evaluateTrajectory");
  if (estimate.size() < 2)
    throw std::invalid_argument("pcl_parallel::evaluation::evaluateTrajectory: needs at least "
                                "2 poses, got " +
                                std::to_string(estimate.size()));
  requireRigidMotions(estimate, "pcl_parallel::evaluation::evaluateTrajectory: the estimate");
  requireRigidMotions(reference, "pcl_parallel::evaluation::evaluateTrajectory: the reference");
  TrajectoryEvaluation ev;
  ev.poses = estimate.size();
  ev.reference_path_length = pathDistances(reference).back();
  ev.ate_unaligned = absoluteTrajectoryError(estimate, reference, Alignment::None);
  ev.ate = options.alignment == Alignment::None
               ? ev.ate_unaligned
               : absoluteTrajectoryError(estimate, reference, options.alignment);
  // Relative errors do not change under a rigid alignment; a Sim(3) one rescales them.
  Poses aligned = estimate;
  if (options.alignment == Alignment::Sim3)
    for (auto& p : aligned)
      p = ev.ate.similarity.apply(p);
  ev.kitti = kittiRelativeError(aligned, reference, options.kitti_lengths, options.kitti_step);
  if (options.rpe_delta >= estimate.size()) // no pair: a table of zeros would be a lie
    throw std::invalid_argument("pcl_parallel::evaluation::evaluateTrajectory: the per-frame "
                                "RPE over " +
                                std::to_string(options.rpe_delta) +
                                " frames has no pose pair in " +
                                std::to_string(estimate.size()) + " poses");
  ev.rpe = frameRelativeError(aligned, reference, options.rpe_delta);
  return ev;
}

} // namespace evaluation
} // namespace pcl_parallel
