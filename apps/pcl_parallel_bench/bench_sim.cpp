/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * "sim": wall time to simulate each preset (ray casting, poses, odometry), 1 vs N
 * threads, and to write it in the app's formats. One timed run a cell (kitti takes
 * minutes); --repeats is ignored.
 */
#include "bench_common.h"

#include <pcl_parallel/sim/presets.h>
#include <pcl_parallel/sim/scan_set_writer.h>

#include <chrono>
#include <cstdio>
#include <filesystem>

namespace pcl_parallel {
namespace bench {

namespace {

void
addPreset(Table& t, const Options& opt, const std::string& name)
{
  std::vector<std::string> row{name};
  double first = 0.0, last = 0.0;
  sim::SimulatedScanSet set;
  for (unsigned threads : opt.threads) {
    const auto start = std::chrono::steady_clock::now();
    set = sim::simulatePreset(name, 1, threads);
    last = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (first == 0.0)
      first = last;
    row.push_back(fmt("%.1f", last));
  }
  std::size_t points = 0;
  for (const auto& s : set.scans)
    points += s->size();
  const auto dir = std::filesystem::temp_directory_path() / ("pcl_parallel_bench_sim_" + name);
  const auto start = std::chrono::steady_clock::now();
  sim::writeScanSet(set, dir.string());
  const double write =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::uintmax_t bytes = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir))
    bytes += e.file_size();
  std::filesystem::remove_all(dir);
  row.insert(row.begin() + 1,
             {fmt("%zu", set.scans.size()),
              fmt("%zu", points / std::max<std::size_t>(1, set.scans.size()))});
  row.push_back(fmt("%.2fx", first / last));
  row.push_back(fmt("%.1f (%.0f MB)", write, bytes / 1e6));
  t.addRow(row);
}

Table
header(const Options& opt)
{
  std::vector<std::string> h{"preset", "scans", "points/scan"};
  for (unsigned threads : opt.threads)
    h.push_back(fmt("%u thread%s [s]", threads, threads == 1 ? "" : "s"));
  h.push_back("speed-up");
  h.push_back("write [s]");
  return Table(h);
}

} // namespace

int
runSimPreset(const Options& opt, const std::string& name)
{
  Table t = header(opt);
  addPreset(t, opt, name);
  t.print();
  return 0;
}

int
runSim(const Options& opt)
{
  std::printf("### Simulating the presets\n\n");
  Table t = header(opt);
  for (const auto& name : sim::presetNames())
    addPreset(t, opt, name);
  t.print();
  if (opt.threads.size() > 1)
    std::printf("\nspin speed-up on %u threads (what the machine gives now): %.2fx\n",
                opt.threads.back(),
                spinSpeedup(opt.threads.back()));
  return 0;
}

} // namespace bench
} // namespace pcl_parallel
