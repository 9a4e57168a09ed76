/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/local_map.h>
#include <pcl_parallel/slam/parameters.h>
#include <pcl_parallel/slam/scan_record.h>
#include <pcl_parallel/slam/sweep_path.h>
#include <pcl_parallel/slam/types.h>

#include <memory>
#include <optional>
#include <utility>

namespace pcl_parallel {
namespace search {
template <typename PointT>
class KdTree;
} // namespace search

namespace slam {

/** What a pICP match says about the pose (the pose graph's information, ScanRecord::
 *  information): its body-frame Hessian (rotation first) over the residual variance
 *  error / weight, reordered translation first. Zero for a non-finite Hessian or a
 *  `weight` (robust pairs) of at most `min_weight`. */
Information
matchInformation(const Eigen::Matrix<double, 6, 6>& hessian,
                 double error,
                 double weight,
                 double min_weight = 6.0);

/** The previous scan as the front end keeps it, in its own frame (its pose is the motion
 *  model's last pose). */
struct PreviousScan {
  MapCloud::Ptr cloud;                      ///< reduced points with normals (NaN where none)
  Cloud::ConstPtr points;                   ///< the same points without normals
  std::shared_ptr<const KdTreeIndex> index; ///< their tree (the scan's own)
  /** True when there is no previous scan. */
  bool
  empty() const
  {
    return !cloud || cloud->empty();
  }
};

/**
 * \brief The front end's pICP (paper Sec. II, IV) against its target: the local map of the
 * recent scans (3DTK's metascan, KISS-ICP) or the previous scan. Gate and kernel adapt
 * (KISS-ICP Sec. III-C), the motion prior enters as a Gaussian prior, and a match is
 * refined within a narrower gate (coarse to fine).
 */
class Matcher {
public:
  /** From resolved parameters (resolve): matcher, guess.guess_from_previous_scan and
   *  num_threads. Throws std::invalid_argument for unresolved ones. */
  explicit Matcher(const Parameters& resolved);
  ~Matcher();

  /** The correspondence distance now: the adaptive threshold's, at most the maximum. */
  double
  gate() const;
  /** The refinement's: the final correspondence distance, at most gate() (none set:
   *  gate()). */
  double
  finalGate() const;

  /** Whether there is something to match against. */
  bool
  hasTarget() const;
  /** The previous scan. */
  const PreviousScan&
  previous() const
  {
    return previous_;
  }

  /** pICP of `source` from `start` against the target, coarse to fine from the gate, its
   *  motion prior at `prior_mean`; `at`: the previous scan's pose. The world pose, or
   *  none if it did not converge. */
  std::optional<Pose>
  match(const Cloud::ConstPtr& source,
        const Pose& start,
        const Pose& prior_mean,
        const Pose& at);

  /** As match, within the final gate alone: `start` is a match already. */
  std::optional<Pose>
  refine(const Cloud::ConstPtr& source,
         const Pose& start,
         const Pose& prior_mean,
         const Pose& at);

  /** pICP of `source` from `start` against the previous scan (at `at`), refined within the
   *  final gate when `refined`, its motion prior at `prior_mean` (null: the start). */
  std::optional<Pose>
  alignToPrevious(const Cloud::ConstPtr& source,
                  const Pose& start,
                  bool refined,
                  const Pose* prior_mean,
                  const Pose& at);

  /** The previous-scan pICP on `source`, for alignInPrevious. */
  void
  usePrevious(const Cloud::ConstPtr& source);
  /** pICP from `start` (in the previous scan's frame) within `gate`, then the final gate,
   *  without a motion prior: a start that nothing predicted. */
  std::optional<Pose>
  alignInPrevious(const Pose& start, double gate);
  /** The last previous-scan match's fitness over pairs within `max_range` (squared
   *  distance, as PCL's getFitnessScore). */
  double
  previousFitness(double max_range) const;

  /** Fits `path` (world poses) to the local map within the final gate (fitSweepPath):
   *  `scan` the raw points, `times` their sweep times. False where there is no map tree
   *  (before a match; scan-to-scan matching) or the fit fails (the path is then
   *  unchanged). */
  bool
  fitPath(SweepPath& path,
          const Cloud& scan,
          const std::vector<float>& times,
          const SweepPathPrior& prior);

  /** The last match's figures into `r` (fitness, information, the scans behind a map
   *  match) and how far it moved the scan from the prediction into the threshold. */
  void
  measure(ScanRecord& r, const Cloud::ConstPtr& source);

  /** Puts a described scan into the local map at `pose` as scan `id` (1 for the first),
   *  and keeps it as the previous scan where that is matched. */
  void
  keep(const ReducedScan& scan, const Pose& pose, std::uint32_t id);
  /** Empties the local map (the first scan is kept again, deskewed). */
  void
  clearMap()
  {
    map_.clear();
  }
  /** Moves the map by a rigid correction (loop closing; the previous scan, in its own
   *  frame, moves with the last pose). */
  void
  applyCorrection(const Pose& correction)
  {
    map_.transform(correction);
  }

private:
  struct Registration;
  /** The map pICP's tree where the last map match used the map as it is now; null before
   *  one, or once keep() has changed the map. */
  const search::KdTree<MapPoint>*
  mapTree() const;
  /** The map pICP's target made the local map as it is now, searched by the map's own
   *  index (LocalMap::index) and paired by its points' normal fields. */
  void
  useMap();
  /** The motion prior's standard deviations where pICP takes one (adaptive threshold and
   *  motion_prior): translation and rotation (rad; infinite for 2D scans, whose walls fix
   *  the heading while wheel odometry's heading error is biased: docs/design.md, "2D
   *  logs"). */
  std::optional<std::pair<double, double>>
  priorSpread() const;
  /** pICP of `source` from `start` against the local map (`to_map`) or the previous scan
   *  (at `at`) within `gate`, then `final_gate` (0: none), its motion prior at
   *  `prior_mean`. The world pose, or none if it did not converge. */
  std::optional<Pose>
  alignTo(bool to_map,
          const Cloud::ConstPtr& source,
          const Pose& start,
          const Pose& prior_mean,
          const Pose& at,
          double gate,
          double final_gate);

  MatcherParameters params_;
  bool keep_previous_; ///< for matches to the previous scan (the target, or the guess's)
  bool planar_;        ///< Parameters::planar
  unsigned num_threads_;
  std::unique_ptr<Registration> icp_;
  LocalMap map_;
  PreviousScan previous_;
  pcl::shared_ptr<search::KdTree<MapPoint>> previous_tree_; ///< over previous_.cloud
  pcl::shared_ptr<search::KdTree<MapPoint>> map_tree_;      ///< over map_.cloud()
  MapCloud::ConstPtr target_; ///< what the map pICP's tree was built from
};

} // namespace slam
} // namespace pcl_parallel
