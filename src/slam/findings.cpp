/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/slam/findings.h>
#include <pcl_parallel/slam/preprocess.h>

#include <cmath>
#include <cstdio>

namespace pcl_parallel {
namespace slam {

std::string
deskewNote(std::size_t timed_scans, std::size_t scans, bool deskew)
{
  if (!deskew)
    return timed_scans == 0 ? ""
                            : "the scans carry per-point times: --deskew would deskew each "
                              "point by its own (unless they are motion-compensated already)";
  if (timed_scans == scans)
    return "deskewed by the points' time field";
  if (timed_scans == 0)
    return "deskewed by azimuth (no per-point times in the scans)";
  return "deskewed by the points' time field in " + std::to_string(timed_scans) + " of " +
         std::to_string(scans) + " scans, else by azimuth";
}

std::string
keyframeWarning(const std::vector<double>& stamps, const DeskewParameters& deskew)
{
  if (!deskew.enabled || deskew.sweep_period > 0.0 || stamps.size() < 2)
    return "";
  std::vector<double> gaps;
  for (std::size_t k = 1; k < stamps.size(); ++k)
    gaps.push_back(stamps[k] - stamps[k - 1]);
  const double gap = median(gaps);
  if (!(gap > kMaxSweepSeconds))
    return "";
  char text[320];
  std::snprintf(text,
                sizeof text,
                "the scans are a median %.2f s apart, longer than a LiDAR sweep: if they are "
                "keyframes, --deskew bends each by its whole step; give the sweep's period "
                "(--sweep-period 0.1 for a 10 Hz LiDAR)",
                gap);
  return text;
}

std::vector<Finding>
findings(const MappingResult& r, const std::vector<int>& numbers)
{
  std::vector<Finding> found;
  char text[512];
  const std::size_t matches = numbers.empty() ? 0 : numbers.size() - 1;
  // Placed from the scans alone: right on a distinct site, possibly a room away where the
  // site repeats.
  if (r.pose_search_won > 0) {
    std::snprintf(text,
                  sizeof text,
                  "pose search: %zu of %zu matches searched (no initial poses), %zu placed by "
                  "it; where the site repeats (rooms, corridors) check them in map.png, or "
                  "give --poses",
                  r.pose_searched,
                  matches,
                  r.pose_search_won);
    found.push_back({text, false});
  }
  // Odometry the scans contradict step after step is in another frame, or broken.
  if (r.odometry_disagreement && *r.odometry_disagreement > kOdometryDisagreementLimit) {
    std::snprintf(text,
                  sizeof text,
                  "pICP moved the scans %.2f times as far from the odometry's steps as the "
                  "steps are long (median of the first %zu steps): is the odometry in the "
                  "scanner's frame? (KITTI's poses.txt is the left camera's: apply "
                  "calib.txt's Tr.) Without it the front end predicts by constant velocity",
                  *r.odometry_disagreement,
                  kOdometryDisagreementSteps);
    found.push_back({text, true});
  }
  // Where the scanner came back: scans whose walls lie in the space another saw through.
  if (r.consistency.pairs > 0) {
    std::snprintf(text,
                  sizeof text,
                  "revisits: %zu of %zu revisiting scans put over %.0f %% of their points into "
                  "the free space of the scan they came back to (front end: %zu); "
                  "report.json: consistency",
                  r.consistency.conflicting,
                  r.consistency.pairs,
                  100.0 * kMaxLoopConflicts,
                  r.consistency_icp.conflicting);
    found.push_back({text, false});
  }
  const std::vector<std::size_t> notable = notableSequenceSteps(r);
  if (!notable.empty()) {
    std::string worst;
    for (std::size_t k = 0; k < notable.size() && k < 3; ++k)
      worst += (k ? ", " : "") + std::to_string(numbers.at(notable[k])) + " (chi2 " +
               std::to_string(std::lround(r.reports[notable[k]].sequence_chi2)) + ")";
    found.push_back({"loop closing disagreed most with the front end's steps to scans " +
                         worst + "; report.json: sequence_chi2",
                     false});
  }
  return found;
}

} // namespace slam
} // namespace pcl_parallel
