/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * "pslam-NAME": the mapping pipeline (slam::Pipeline) end to end on a simulated preset,
 * 1 vs N threads. The preset is written to disk in the app's formats first; each run then
 * streams the scans as pcl_pslam does: read a scan, feed it, next. Reported per stage
 * (reading included), per scan and as scans per second, with the errors (ATE, per-frame
 * RPE) of the odometry, the front end and the final poses against the truth.
 */
#include "bench_common.h"
#include "preset_reader.h"

#include <pcl_parallel/evaluation/trajectory_error.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/uos.h>
#include <pcl_parallel/sim/presets.h>
#include <pcl_parallel/sim/scan_set_writer.h>
#include <pcl_parallel/slam/pipeline.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>

namespace pcl_parallel {
namespace bench {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double
since(Clock::time_point t)
{
  return std::chrono::duration<double>(Clock::now() - t).count();
}

} // namespace

int
runPslamPreset(const Options& opt, const std::string& preset, bool use_odometry)
{
  const auto set = sim::simulatePreset(preset, 1u, 0u);
  const fs::path dir = fs::temp_directory_path() / ("pcl_parallel_bench_" + preset);
  fs::remove_all(dir);
  sim::writeScanSet(set, dir.string());
  const PresetReader reader(dir.string(), set.point_times.empty());
  const auto truth = io::loadKittiPoses((dir / "ground_truth.txt").string());
  const std::size_t n = truth.size();
  std::size_t points = 0;
  for (const auto& s : set.scans)
    points += s->size();
  std::printf("### pcl_pslam pipeline: preset %s (%s)\n\n",
              preset.c_str(),
              use_odometry ? "from its odometry" : "no odometry: constant velocity");
  std::printf("%zu scans, %zu points (%.0f per scan), read from %s; default parameters%s. "
              "One run per thread count (deterministic: the errors are the same).\n\n",
              n,
              points,
              double(points) / n,
              dir.c_str(),
              reader.uos ? "" : ", deskewed");

  const unsigned max_threads = *std::max_element(opt.threads.begin(), opt.threads.end());
  const double spin_before = spinSpeedup(max_threads);
  Table t({"threads",
           "read [s]",
           "front end [s]",
           "loop det. [s]",
           "loop closing [s]",
           "total [s]",
           "ms/scan",
           "scans/s",
           "relaxations"});
  evaluation::TrajectoryEvaluation odo_eval, fe_eval, final_eval;
  double total_one = 0.0;
  slam::StageTimes one; // the first thread count's, for each stage's speed-up
  double read_one = 0.0;
  std::vector<Eigen::Matrix4d> poses_one; // the first thread count's final poses
  std::string differ;                     // thread counts whose poses are not bit-identical
  for (unsigned threads : opt.threads) {
    slam::Parameters p;
    p.num_threads = threads;
    p.deskew.enabled = !reader.uos;
    slam::Pipeline pipeline(p);
    double read = 0.0;
    std::vector<Eigen::Matrix4d> odometry; // as read with the scans
    const auto start = Clock::now();
    for (std::size_t i = 0; i < n; ++i) {
      const auto r0 = Clock::now();
      Eigen::Matrix4d odo;
      const auto scan = reader.scan(i, odo);
      read += since(r0);
      odometry.push_back(odo);
      pipeline.addScan(*scan,
                       use_odometry ? std::optional<Eigen::Matrix4d>(odo) : std::nullopt);
    }
    pipeline.finish();
    const double total = since(start);
    const auto& st = pipeline.times();
    if (total_one == 0.0)
      total_one = total, one = st, read_one = read;
    auto cell = [](double s, double s_one) {
      return s > 0.0 ? fmt("%.2f (%.2fx)", s, s_one / s) : fmt("%.2f", s);
    };
    t.addRow({fmt("%u", threads),
              cell(read, read_one),
              cell(st.front_end + st.preprocess, one.front_end + one.preprocess),
              cell(st.loop_detection, one.loop_detection),
              cell(st.loop_closing, one.loop_closing),
              fmt("%.2f (%.2fx)", total, total_one / total),
              fmt("%.1f", 1e3 * total / n),
              fmt("%.1f", n / total),
              fmt("%d", pipeline.relaxations())});
    evaluation::EvaluationOptions eo;
    odo_eval = evaluation::evaluateTrajectory(odometry, truth, eo);
    fe_eval = evaluation::evaluateTrajectory(pipeline.frontEndPoses(), truth, eo);
    final_eval = evaluation::evaluateTrajectory(pipeline.poses(), truth, eo);
    if (poses_one.empty())
      poses_one = pipeline.poses();
    else if (pipeline.poses() != poses_one)
      differ += fmt(" %u", threads);
    if (threads == opt.threads.front())
      std::printf("kept per scan: %zu bytes; %zu links\n\n",
                  pipeline.bytesPerScan(),
                  pipeline.links().size());
  }
  t.print();
  std::printf("Machine check: a compute-bound OpenMP loop ran %.2fx faster on %u threads than "
              "on 1 before this table and %.2fx after it (%u on an idle machine).\n",
              spin_before,
              max_threads,
              spinSpeedup(max_threads),
              max_threads);
  std::printf("Final poses bit-identical for every thread count: %s.\n",
              differ.empty() ? "yes" : ("NO, they differ at" + differ).c_str());
  Table e({"poses",
           "ATE rmse [m]",
           "ATE rot. rmse [deg]",
           "RPE [%]",
           "RPE [deg/m]",
           "per-frame RPE [m]"});
  auto row = [&](const char* what, const evaluation::TrajectoryEvaluation& v) {
    e.addRow({what,
              fmt("%.4f", v.ate.translation.rmse),
              fmt("%.3f", v.ate.rotation_deg.rmse),
              fmt("%.3f", v.kitti.translation_percent),
              fmt("%.5f", v.kitti.rotation_deg_per_m),
              fmt("%.4f", v.rpe.translation.rmse)});
  };
  std::printf("\n");
  if (use_odometry)
    row("odometry", odo_eval);
  row("front end", fe_eval);
  row("final", final_eval);
  e.print();
  fs::remove_all(dir);
  return 0;
}

} // namespace bench
} // namespace pcl_parallel
