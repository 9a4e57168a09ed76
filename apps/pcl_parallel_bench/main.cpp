/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pcl_parallel_bench: side-by-side timings (ours vs PCL, 1 vs N threads), medians over
 * repeats, printed as markdown tables for docs/benchmarks.md. Not a test: it asserts
 * nothing about time.
 */
#include "bench_common.h"

#include <pcl_parallel/parallel.h>

#include <pcl/console/print.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <map>
#include <sstream>

namespace pcl_parallel {
namespace bench {

double
spinSpeedup(unsigned threads)
{
  auto spin = [](unsigned t) {
    double best = 1e30;
    for (int r = 0; r < 3; ++r) {
      const auto start = std::chrono::steady_clock::now();
      double sink = 0.0;
#pragma omp parallel num_threads(t) reduction(+ : sink)
      {
        double y = 0.0;
        const long n = 200000000L / static_cast<long>(t);
        for (long i = 0; i < n; ++i)
          y += static_cast<double>(i) * 1e-9;
        sink += y;
      }
      volatile double keep = sink;
      (void)keep;
      best = std::min(
          best,
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
    return best;
  };
  return spin(1) / spin(threads);
}

} // namespace bench
} // namespace pcl_parallel

namespace {

void
usage()
{
  std::printf(
      "usage: pcl_parallel_bench <what> [--data DIR] [--repeats N] [--threads 1,2,...] "
      "[--no-reference]\n"
      "  what: kdtree | filters | icp | lum (= lum-bunny + lum-scaling) | all\n"
      "        pslam (every preset, minutes) | pslam-office | pslam-hannover | pslam-riegl | "
      "pslam-kitti | pslam-kitti-cv\n"
      "        sim (every preset, minutes) | sim-office | sim-hannover | sim-riegl | "
      "sim-kitti\n"
      "        memory (not in all: ICP on 20 million points, a few GB)\n"
      "        contention (not in all: 1 vs N threads beside CPU-bound processes it starts)\n"
      "        accuracy (not in all: the accuracy studies the tests assert parts of, minutes)\n"
      "        = lum-seeds + real-car + hannover-steps\n"
      "  --data     reference data directory (default: the build's PCL_PARALLEL_DATA_DIR)\n"
      "  --repeats  timed repeats per cell, median reported (default 5)\n"
      "  --threads  thread counts to compare (default: 1 and all cores)\n"
      "  --no-reference  icp: time ours alone, not PCL and Open3D beside it (thread scaling\n"
      "             on many cores, where the single-thread reference would take most of the "
      "run)\n");
}

} // namespace

int
main(int argc, char** argv)
{
  using namespace pcl_parallel::bench;
  if (argc < 2) {
    usage();
    return 2;
  }
  pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
  const std::string what = argv[1];
  Options opt;
  opt.data_dir = PCL_PARALLEL_DATA_DIR;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--no-reference") {
      opt.reference = false;
      continue;
    }
    if (i + 1 >= argc) {
      usage();
      return 2;
    }
    if (a == "--data")
      opt.data_dir = argv[++i];
    else if (a == "--repeats")
      opt.repeats = std::max(1, std::atoi(argv[++i]));
    else if (a == "--threads") {
      std::stringstream ss(argv[++i]);
      std::string tok;
      while (std::getline(ss, tok, ','))
        opt.threads.push_back(static_cast<unsigned>(std::atoi(tok.c_str())));
    }
    else {
      usage();
      return 2;
    }
  }
  if (opt.threads.empty()) {
    opt.threads.push_back(1);
    if (pcl_parallel::hardwareThreads() > 1)
      opt.threads.push_back(pcl_parallel::hardwareThreads());
  }

  const std::map<std::string, int (*)(const Options&)> benches = {
      {"kdtree", runKdTree},
      {"filters", runFilters},
      {"lum", runLum},
      {"lum-bunny", runLumBunny},
      {"lum-scaling", runLumScaling},
      {"lum-seeds", runLumSeeds},
      {"icp", runIcp},
      {"pslam-office", [](const Options& o) { return runPslamPreset(o, "office", true); }},
      {"pslam-hannover", [](const Options& o) { return runPslamPreset(o, "hannover", true); }},
      {"pslam-riegl", [](const Options& o) { return runPslamPreset(o, "riegl", true); }},
      {"pslam-kitti", [](const Options& o) { return runPslamPreset(o, "kitti", true); }},
      {"pslam-kitti-cv", [](const Options& o) { return runPslamPreset(o, "kitti", false); }},
      {"sim-office", [](const Options& o) { return runSimPreset(o, "office"); }},
      {"sim-hannover", [](const Options& o) { return runSimPreset(o, "hannover"); }},
      {"sim-riegl", [](const Options& o) { return runSimPreset(o, "riegl"); }},
      {"sim-kitti", [](const Options& o) { return runSimPreset(o, "kitti"); }},
      {"memory", runMemory},
      {"contention", runContention},
      {"real-car", runRealCar},
      {"hannover-steps", runHannoverSteps}};
  if (what == "all") {
    int rc = 0;
    for (const auto& b : benches)
      if (b.first.find('-') == std::string::npos && b.first != "memory" &&
          b.first != "contention") // parts: in groups
        rc |= b.second(opt);
    return rc;
  }
  if (what == "sim")
    return runSim(opt);
  if (what == "accuracy")
    return runLumSeeds(opt) | runRealCar(opt) | runHannoverSteps(opt);
  if (what == "pslam") { // every preset, and kitti without odometry
    int rc = 0;
    for (const auto& b : benches)
      if (b.first.rfind("pslam-", 0) == 0)
        rc |= b.second(opt);
    return rc;
  }
  const auto it = benches.find(what);
  if (it == benches.end()) {
    usage();
    return 2;
  }
  return it->second(opt);
}
