/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/parameters.h>
#include <pcl_parallel/slam/scan_record.h>
#include <pcl_parallel/slam/types.h>

#include <Eigen/Geometry>

#include <functional>
#include <optional>
#include <vector>

namespace pcl_parallel {
namespace slam {

class Matcher;
class MotionModel;
class Reducer;

/**
 * \brief Where the front end's pICP starts without odometry: the prediction's match to
 * the previous scan, or a better start where that looks wrong: speed and turn-rate
 * hypotheses beside the prediction, and a search over all headings and translations
 * (correlativeSearch), judged by their fit, overlap and free-space conflicts with the
 * previous scan (docs/design.md, "Speed hypotheses", "Pose search"). With odometry, the
 * prediction.
 */
class PoseGuess {
public:
  /** A cloud of the scan (scanner frame, deskewed by the prediction's motion) as deskewed
   *  by the motion a start implies (MotionModel::sweepOfMatch), or null where the
   *  prediction's deskewing holds for it. */
  using StartDeskew = std::function<Cloud::Ptr(const Cloud& cloud, const Pose& start)>;

  /** The stages it asks: the matcher's previous-scan pICP, the reducer's normals and the
   *  motion model's last pose and heading (all outlive it); resolved parameters
   *  (resolve). */
  PoseGuess(const Parameters& resolved,
            Matcher& matcher,
            const Reducer& reducer,
            const MotionModel& motion);

  /** The start for scan `r` (r.prediction predicted; its report takes which start won:
   *  start_offset, start_turn, start_heading, pose_searched). `scan` is `source`'s
   *  reduced scan; the pose search describes it. With `deskew`, each speed and turn-rate
   *  hypothesis and each pose-search candidate is matched and judged on the scan deskewed
   *  by its own motion. */
  Pose
  guess(const Cloud::ConstPtr& source,
        ReducedScan& scan,
        bool odometry,
        ScanRecord& r,
        const StartDeskew& deskew = {});

  /** The motion prior's mean for the match from `start`: the prediction, or the start
   *  where the pose search placed the scan, the prediction being what it found wrong
   *  (docs/design.md, "Where the site repeats"). */
  static const Pose&
  priorMean(const ScanRecord& r, const Pose& start);

private:
  /** Starts tried beside the prediction without odometry (speed_hypotheses). */
  struct Hypotheses {
    /** Speed: along `travel` (scanner frame) at -2..2 sigma of the gate; none at 0. */
    Eigen::Vector3d travel = Eigen::Vector3d::Zero();
    double sigma = 0.0;
    double speed = 0.0; ///< the predicted step's length along `travel`
    /** Turn rate: the predicted turn stopped and doubled; none at angle 0. */
    Eigen::AngleAxisd turn = Eigen::AngleAxisd(0.0, Eigen::Vector3d::UnitZ());
    double range = 0.0; ///< the scan's median range: poses compared by motionDisplacement
    bool
    any() const
    {
      return sigma > 0.0 || turn.angle() > 0.0;
    }
  };
  Hypotheses
  hypotheses(const Cloud& source, const Pose& prediction) const;
  /** Right after `own` (the prediction's match to the previous scan): the hypotheses'
   *  best match where one beats it, the pose search's where even that looks wrong. */
  std::optional<Pose>
  betterGuess(const Cloud::ConstPtr& source,
              ReducedScan& scan,
              const std::optional<Pose>& own,
              ScanRecord& r,
              const StartDeskew& deskew);
  /** The best of the hypotheses' matches if one fits better and ends elsewhere, each on
   *  the sample `deskew` gives for its start (where it gives one). */
  std::optional<Pose>
  bestHypothesis(const Cloud::ConstPtr& source,
                 const Pose& prediction,
                 const std::optional<Pose>& own,
                 const Hypotheses& h,
                 ScanRecord& r,
                 const StartDeskew& deskew);
  /** Where `own` looks wrong: the best of correlativeSearch's candidates matched, if it
   *  overlaps the previous scan 1.25 times more, agrees with it more (overlap less
   *  free-space conflicts) and ends elsewhere; each matched and judged on the scan
   *  `deskew` gives for it (where it gives one). */
  std::optional<Pose>
  searchPose(const Cloud::ConstPtr& source,
             ReducedScan& scan,
             const std::optional<Pose>& own,
             double range,
             ScanRecord& r,
             const StartDeskew& deskew);
  /** Keeps the overlap of the latest match to the previous scan (the recent ones). */
  void
  keepOverlap(double overlap);
  /** How close two starts or matches lie in one basin: the refinement gate, at least a
   *  voxel. */
  double
  sameSolution() const;
  /** Whether a match (previous scan's frame) puts the scanner where the previous scan
   *  was taken: there both share their sampling pattern (docs/design.md, "Standing
   *  still"). */
  bool
  atPreviousScan(const Pose& local) const;
  /** Whether `other` may replace `leader` (previous scan's frame, compared at `range`). */
  bool
  isRival(const Pose& leader, const Pose& other, double range) const;

  Parameters params_; ///< resolved
  Matcher& matcher_;
  const Reducer& reducer_;
  const MotionModel& motion_;
  std::vector<double> overlaps_; ///< of the recent matches to the previous scan
};

} // namespace slam
} // namespace pcl_parallel
