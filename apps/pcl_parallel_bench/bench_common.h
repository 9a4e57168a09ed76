/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Shared pieces of the benchmark: timing with medians over repeats, and a plain table.
 */
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace bench {

/** Options every sub-benchmark understands. */
struct Options {
  std::string data_dir;          ///< reference data (3dtk_dat, stanford_bunny, ...)
  int repeats = 5;               ///< timed repeats per cell; the median is reported
  std::vector<unsigned> threads; ///< thread counts to compare (default 1 and all cores)
  bool reference = true;         ///< time PCL (and Open3D) beside ours; off: scaling only
};

/** Wall time in seconds of one run of fn. */
inline double
seconds(const std::function<void()>& fn)
{
  const auto start = std::chrono::steady_clock::now();
  fn();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/** Median and best wall time in seconds of `repeats` runs of fn, after one untimed
 *  warm-up. The median is what tables rank by; the best is less sensitive to other
 *  processes on a shared machine. */
struct Timing {
  double median, best;
};
inline Timing
timeRuns(int repeats, const std::function<void()>& fn)
{
  fn();
  std::vector<double> t;
  for (int r = 0; r < std::max(1, repeats); ++r)
    t.push_back(seconds(fn));
  std::sort(t.begin(), t.end());
  return {t[t.size() / 2], t.front()};
}

/** Median wall time in seconds (see timeRuns). */
inline double
medianSeconds(int repeats, const std::function<void()>& fn)
{
  return timeRuns(repeats, fn).median;
}

/** What the machine gives right now: speed-up of a compute-bound, embarrassingly parallel
 *  OpenMP loop on `threads` threads over 1 thread (best of 3). On an idle machine it is
 *  ~threads; on a machine shared with other jobs it shows how much parallelism there was
 *  to have. Print it with every table that compares thread counts. */
double
spinSpeedup(unsigned threads);

/** A markdown table printed to stdout, so the output pastes into docs/benchmarks.md. */
class Table {
public:
  explicit Table(std::vector<std::string> header)
      : header_(std::move(header))
  {}
  void
  addRow(std::vector<std::string> row)
  {
    rows_.push_back(std::move(row));
  }
  void
  print() const
  {
    printRow(header_);
    std::string rule = "|";
    for (std::size_t i = 0; i < header_.size(); ++i)
      rule += "---|";
    std::printf("%s\n", rule.c_str());
    for (const auto& r : rows_)
      printRow(r);
    std::printf("\n");
    std::fflush(stdout);
  }

private:
  static void
  printRow(const std::vector<std::string>& row)
  {
    std::string line = "|";
    for (const auto& c : row)
      line += " " + c + " |";
    std::printf("%s\n", line.c_str());
  }
  std::vector<std::string> header_;
  std::vector<std::vector<std::string>> rows_;
};

/** printf-style formatting into a std::string. */
template <typename... Args>
std::string
fmt(const char* format, Args... args)
{
  char buf[256];
  std::snprintf(buf, sizeof(buf), format, args...);
  return buf;
}

int
runKdTree(const Options& opt);

int
runLum(const Options& opt);
int
runLumBunny(const Options& opt);
int
runLumScaling(const Options& opt);
/** test_lum's bunny convergence over several start draws (accuracy; not in all). */
int
runLumSeeds(const Options& opt);
/** pcl::IterativeClosestPoint vs ParallelIterativeClosestPoint (and Open3D if built). */
int
runIcp(const Options& opt);
/** The pcl_pslam pipeline on the simulated scan set, stage by stage. */
int
runPslamPreset(const Options& opt, const std::string& preset, bool use_odometry);
/** Simulating the presets (sim/presets.h), 1 vs N threads; "sim-NAME" for one preset. */
int
runSim(const Options& opt);
int
runSimPreset(const Options& opt, const std::string& name);
/** Memory: the k-d tree's bytes per point, ICP's peak on 1, 5, 20 million points. */
int
runMemory(const Options& opt);

/** pICP, pLUM and the pipeline at 1 and N threads, idle and beside CPU-bound processes,
 *  on the library's pool and on OpenMP. */
int
runContention(const Options& opt);

/** Accuracy studies moved out of ctest (not in all; bench_accuracy.cpp): the front end
 *  on the real Ouster car drive, and without poses on the whole hannover preset. */
int
runRealCar(const Options& opt);
int
runHannoverSteps(const Options& opt);

/** voxelCentroid vs pcl::VoxelGrid, voxelNearestToCentroid vs pcl::UniformSampling. */
int
runFilters(const Options& opt);

} // namespace bench
} // namespace pcl_parallel
