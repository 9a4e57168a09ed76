/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * "pslam": the pcl_pslam pipeline on the built-in simulated scan set (the demo), stage by
 * stage, 1 vs N threads: reduction, sequential pICP, pLUM, and the pose errors reached.
 */
#include "bench_common.h"
#include "slam_pipeline.h"

#include <pcl_parallel/sim/simulated_scans.h>

#include <chrono>
#include <cstdio>
#include <map>

namespace pcl_parallel {
namespace bench {

int
runPslam(const Options& opt)
{
  const auto set = sim::simulateScanSet(sim::SimulationParameters());
  std::size_t points = 0;
  for (const auto& s : set.scans)
    points += s->size();
  std::printf("### pcl_pslam: simulated scan set (the demo)\n\n");
  std::printf("%zu scans, %zu points; pcl_pslam's default parameters (10 cm voxels, pICP "
              "0.5 m / 100 iterations, loops within 3 m, pLUM point-to-plane with 5 link "
              "steps, gate 1 m -> 0.2 m). Stage times of one run each; the runs are "
              "deterministic, so the errors are the same for every thread count.\n\n",
              set.scans.size(),
              points);
  Table t({"threads",
           "reduce [s]",
           "pICP [s]",
           "pLUM [s]",
           "total [s]",
           "pLUM iterations",
           "final max error"});
  double total_one = 0.0;
  for (unsigned threads : opt.threads) {
    pcl_pslam::Parameters params;
    params.num_threads = threads;
    using Clock = std::chrono::steady_clock;
    std::map<std::string, Clock::time_point> last; // last progress event of each stage
    const auto start = Clock::now();
    const pcl_pslam::Result r = pcl_pslam::run(
        set.scans, set.odometry, params, [&](const std::string& stage, int, int) {
          last[stage] = Clock::now();
        });
    const auto end = Clock::now();
    auto seconds = [](Clock::time_point a, Clock::time_point b) {
      return std::chrono::duration<double>(b - a).count();
    };
    const double total = seconds(start, end);
    if (total_one == 0.0)
      total_one = total;
    const auto e = pcl_pslam::poseErrors(r.final, set.truth);
    t.addRow({fmt("%u", threads),
              fmt("%.2f", seconds(start, last["reduce"])),
              fmt("%.2f", seconds(last["reduce"], last["icp"])),
              fmt("%.2f", seconds(last["icp"], end)),
              fmt("%.2f (%.2fx)", total, total_one / total),
              fmt("%d", r.lum_iterations),
              fmt("%.3f m, %.3f deg", e.max_trans, e.max_rot * 180.0 / M_PI)});
  }
  t.print();
  return 0;
}

} // namespace bench
} // namespace pcl_parallel
