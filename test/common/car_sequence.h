/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The real keyframe sequences of ../shared/data mapped as `pcl_pslam run` maps them, and
 * the figures test_real_sequences asserts on a part of them and `pcl_parallel_bench
 * real-car` prints for the whole (docs/benchmarks.md, "Real sequences").
 */
#pragma once

#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/slam/pipeline.h>

#include <algorithm>
#include <cstdio>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace pcl_parallel {
namespace test {

/** DIR/NNNNNN.bin, the sequences' scan files. */
inline std::string
binPath(const std::string& dir, std::size_t i)
{
  char name[32]; // any size_t's digits and ".bin"
  std::snprintf(name, sizeof(name), "%06zu.bin", i);
  return dir + "/" + name;
}

/** The pipeline with parameters p over scans first..n-1 of DIR/bin, with their odometry
 *  and time stamps if given (and its per-scan reports if asked): the final poses, or with
 * p.loops.enabled false the front end's alone (`pcl_pslam run --no-loops`). */
inline slam::Poses
mapSequence(const std::string& dir,
            std::size_t n,
            const slam::Parameters& p,
            const slam::Poses* odometry = nullptr,
            const std::vector<double>* stamps = nullptr,
            std::vector<slam::ScanReport>* reports = nullptr,
            std::size_t first = 0)
{
  slam::Pipeline pipeline(p);
  for (std::size_t i = first; i < n; ++i)
    pipeline.addScan(*io::loadScan(binPath(dir, i)),
                     odometry ? std::optional<slam::Pose>((*odometry)[i]) : std::nullopt,
                     stamps ? std::optional<double>((*stamps)[i]) : std::nullopt);
  pipeline.finish();
  if (reports)
    *reports = pipeline.reports();
  return p.loops.enabled ? pipeline.poses() : pipeline.frontEndPoses();
}

/** ... with the default parameters on 2 threads. */
inline slam::Poses
mapSequence(const std::string& dir,
            std::size_t n,
            const slam::Poses* odometry = nullptr,
            bool close_loops = false)
{
  slam::Parameters p;
  p.loops.enabled = close_loops;
  p.num_threads = 2;
  return mapSequence(dir, n, p, odometry);
}

/** The car's steps: the share going forward (along -x) and the path to keyframe 60, the
 *  poses starting at keyframe `first`. */
inline std::pair<double, double>
carProgress(const slam::Poses& poses, std::size_t first = 0)
{
  std::size_t forward = 0;
  double pull_away = 0.0;
  for (std::size_t i = 1; i < poses.size(); ++i) {
    const slam::Pose step = poses[i - 1].inverse() * poses[i];
    forward += step(0, 3) < 0.0 ? 1 : 0;
    if (first + i <= 60)
      pull_away += step.topRightCorner<3, 1>().norm();
  }
  return {static_cast<double>(forward) / static_cast<double>(poses.size() - 1), pull_away};
}

/** The front end alone on 2 threads, deskewed by one sweep of sweep_period seconds (0: by
 *  the whole step), as `pcl_pslam run --no-loops --deskew [--sweep-period S]`. */
inline slam::Parameters
deskewedFrontEnd(double sweep_period)
{
  slam::Parameters p;
  p.loops.enabled = false;
  p.num_threads = 2;
  p.deskew.enabled = true;
  p.deskew.sweep_period = sweep_period;
  return p;
}

/** How far pICP moved the median keyframe from the motion prior (ScanReport::correction,
 *  translation plus rotation at the median range), from the third keyframe on. */
inline double
medianCorrection(const std::vector<slam::ScanReport>& reports)
{
  std::vector<double> c;
  for (std::size_t i = 2; i < reports.size(); ++i)
    c.push_back(reports[i].correction);
  std::nth_element(c.begin(), c.begin() + c.size() / 2, c.end());
  return c[c.size() / 2];
}

/** The median corrections of keyframes first..n-1 with their time stamps, deskewed by
 *  one 0.1 s sweep and by the whole step (both must map all n - first keyframes). */
struct CarCorrections {
  double one_sweep = 0.0, whole_step = 0.0;
  bool complete = true;
};
inline CarCorrections
carCorrections(const std::string& dir,
               const std::vector<double>& times,
               std::size_t n,
               std::size_t first = 0)
{
  CarCorrections c;
  const auto correction = [&](double sweep_period) {
    std::vector<slam::ScanReport> reports;
    const slam::Poses poses =
        mapSequence(dir, n, deskewedFrontEnd(sweep_period), nullptr, &times, &reports, first);
    c.complete = c.complete && poses.size() == n - first;
    return medianCorrection(reports);
  };
  c.one_sweep = correction(0.1);
  c.whole_step = correction(0.0);
  return c;
}

/** The pull-away from keyframe `first` with the time stamps, deskewed by one sweep, over
 *  keyframes first..n-1 (n > 47): the path to keyframe 60, the shortest step of keyframes
 *  20-46 (0.4-0.6 s apart at ~14 m/s), and whether a match started ahead of constant
 *  velocity. */
struct CarPullAway {
  slam::Poses poses;
  double pull_away = 0.0, shortest = 1e9;
  bool started_ahead = false;
};
inline CarPullAway
carPullAway(const std::string& dir,
            const std::vector<double>& times,
            std::size_t n,
            std::size_t first,
            const slam::Parameters& p)
{
  CarPullAway r;
  std::vector<slam::ScanReport> reports;
  r.poses = mapSequence(dir, n, p, nullptr, &times, &reports, first);
  if (r.poses.size() != n - first)
    return r;
  r.pull_away = carProgress(r.poses, first).second;
  for (std::size_t k = 20; k < 46; ++k)
    r.shortest = std::min(r.shortest,
                          (r.poses[k + 1 - first].topRightCorner<3, 1>() -
                           r.poses[k - first].topRightCorner<3, 1>())
                              .norm());
  r.started_ahead = std::any_of(reports.begin(), reports.end(), [](const slam::ScanReport& s) {
    return s.start_offset > 0.0;
  });
  return r;
}

} // namespace test
} // namespace pcl_parallel
