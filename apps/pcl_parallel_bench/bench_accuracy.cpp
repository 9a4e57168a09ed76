/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Accuracy studies whose parts the tests assert (not timings):
 *  "real-car": the front end on the whole Ouster car drive of ../shared/data
 *  (mulran_riverside02_keyframes, PROVENANCE.txt): how far pICP moves each keyframe from
 *  the time-stamped constant-velocity prediction, deskewed by one sweep and by the whole
 *  step, and the pull-away from each of the start keyframes 0-3, against the local map
 *  and scan-to-scan (test_real_sequences).
 *  "hannover-steps": the front end without poses over the whole hannover preset, a 2D
 *  scanner carried stop-and-go down corridors and across a crossing: its worst steps
 *  against the truth (test_slam's Pipeline.StopAndGoWithoutPosesThroughCorridors...).
 */
#include "bench_common.h"
#include "car_sequence.h"

#include <pcl_parallel/evaluation/pose_error.h>
#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/sim/presets.h>

#include <cmath>
#include <filesystem>

namespace pcl_parallel {
namespace bench {

namespace {

/** Median corrections over all keyframes and from keyframe 200 on, past the pull-away:
 *  deskewed by one sweep's share of the step the prediction per second stays where pICP
 *  finds the keyframe; deskewed by the whole step (right only for consecutive sweeps) the
 *  scans are bent and it lies farther off. test_slam's KeyframesAreDeskewedByOneSweepsShare
 *  asserts the rule against the truth of the kitti preset. */
void
printCorrections(const std::string& dir, const std::vector<double>& times)
{
  std::printf("### Real sequences: mulran keyframes predicted by their times\n\n"
              "`pcl_pslam run BIN -s S --deskew [--sweep-period 0.1] --no-loops`, 2 threads: "
              "median of ScanReport::correction from the third keyframe mapped on.\n\n");
  Table t({"keyframes", "one sweep (0.1 s) [m]", "whole step [m]", "time [s]"});
  for (const std::size_t first : {std::size_t{0}, std::size_t{200}}) {
    test::CarCorrections c;
    const double s =
        seconds([&]() { c = test::carCorrections(dir, times, times.size(), first); });
    t.addRow({fmt("%zu-%zu%s", first, times.size() - 1, c.complete ? "" : " (incomplete)"),
              fmt("%.3f", c.one_sweep),
              fmt("%.3f", c.whole_step),
              fmt("%.1f", s)});
  }
  t.print();
}

/** The pull-away to keyframe 60 from start keyframes 0-3, both match targets. */
void
printPullAway(const std::string& dir, const std::vector<double>& times)
{
  std::printf("### Real sequences: mulran pull-away from any start keyframe\n\n"
              "`pcl_pslam run BIN -s S --deskew --sweep-period 0.1 --no-loops "
              "[--scan-to-scan]`, keyframes S-69, 2 threads. test_real_sequences asserts "
              "over 250 m to keyframe 60 and every step of keyframes 20-46 over 4 m.\n\n");
  Table t({"target",
           "start",
           "to keyframe 60 [m]",
           "shortest step 20-46 [m]",
           "started ahead",
           "time [s]"});
  slam::Parameters p = test::deskewedFrontEnd(0.1);
  for (const slam::MatchTarget target :
       {slam::MatchTarget::kLocalMap, slam::MatchTarget::kPreviousScan}) {
    p.matcher.target = target;
    for (std::size_t first = 0; first < 4; ++first) {
      test::CarPullAway r;
      const double s = seconds([&]() { r = test::carPullAway(dir, times, 70, first, p); });
      t.addRow({target == slam::MatchTarget::kLocalMap ? "local map" : "scan-to-scan",
                fmt("%zu", first),
                fmt("%.0f", r.pull_away),
                fmt("%.2f", r.shortest),
                r.started_ahead ? "yes" : "no",
                fmt("%.1f", s)});
    }
  }
  t.print();
}

} // namespace

int
runRealCar(const Options& opt)
{
  const std::filesystem::path root =
      std::filesystem::path(opt.data_dir) / "mulran_riverside02_keyframes";
  if (!std::filesystem::exists(root / "times.txt")) {
    std::printf("real-car: %s not found, skipped\n\n", (root / "times.txt").c_str());
    return 0;
  }
  const std::vector<double> times = io::loadKittiTimes((root / "times.txt").string());
  printCorrections((root / "bin").string(), times);
  printPullAway((root / "bin").string(), times);
  return 0;
}

int
runHannoverSteps(const Options&)
{
  sim::PresetOptions o;
  o.num_threads = 2;
  const sim::SimulatedScanSet set = sim::simulatePreset("hannover", o);
  slam::Parameters p;
  p.num_threads = 2;
  p.loops.enabled = false;
  slam::Pipeline pipeline(p);
  const double s = seconds([&]() {
    for (const auto& scan : set.scans)
      pipeline.addScan(*scan);
    pipeline.finish();
  });
  const slam::Poses& poses = pipeline.frontEndPoses();
  std::printf("### Hannover preset without poses: the front end's steps\n\n"
              "%zu scans, front end only, 2 threads, %.1f s. Each step's error against the "
              "truth's step; test_slam asserts every step of its first 200 scans within "
              "0.4 m and 1 degree.\n\n",
              set.scans.size(),
              s);
  Table t({"worst by", "scan", "step [m]", "error [m]", "error [deg]"});
  std::size_t worst_distance = 1, worst_angle = 1, over = 0;
  std::vector<evaluation::PoseError> e(poses.size());
  for (std::size_t i = 1; i < poses.size(); ++i) {
    e[i] = evaluation::poseError(poses[i - 1].inverse() * poses[i],
                                 set.truth[i - 1].inverse() * set.truth[i]);
    worst_distance = e[i].distance > e[worst_distance].distance ? i : worst_distance;
    worst_angle = e[i].angle > e[worst_angle].angle ? i : worst_angle;
    over += e[i].distance >= 0.4 || e[i].angle >= M_PI / 180.0 ? 1 : 0;
  }
  for (const auto& [what, i] :
       {std::pair{"distance", worst_distance}, std::pair{"angle", worst_angle}})
    t.addRow(
        {what,
         fmt("%zu", i),
         fmt("%.2f",
             (set.truth[i].topRightCorner<3, 1>() - set.truth[i - 1].topRightCorner<3, 1>())
                 .norm()),
         fmt("%.3f", e[i].distance),
         fmt("%.3f", e[i].angle * 180.0 / M_PI)});
  t.print();
  std::printf("Steps off by 0.4 m or 1 degree or more: %zu.\n\n", over);
  return 0;
}

} // namespace bench
} // namespace pcl_parallel
