/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Voxel sampling benchmark: voxelCentroid against pcl::VoxelGrid and
 * voxelNearestToCentroid against pcl::UniformSampling (the nearest PCL offers: the point
 * nearest each voxel's centre), on one full sweep, at the voxel sizes the front end uses.
 */
#include "bench_common.h"

#include <pcl_parallel/filters/voxel_grid.h>
#include <pcl_parallel/sim/presets.h>

#include <pcl/filters/uniform_sampling.h>
#include <pcl/filters/voxel_grid.h>

namespace pcl_parallel {
namespace bench {

int
runFilters(const Options& opt)
{
  using Cloud = pcl::PointCloud<pcl::PointXYZ>;
  sim::PresetOptions po;
  po.max_scans = 1;
  const Cloud::Ptr sweep = sim::simulatePreset("kitti", po).scans.front();
  const unsigned max_threads = *std::max_element(opt.threads.begin(), opt.threads.end());
  const double spin_before = spinSpeedup(max_threads);
  std::printf("## Voxel sampling: one kitti preset sweep (%zu points, m), median of %d\n\n",
              sweep->size(),
              opt.repeats);
  Table table(
      {"voxel [m]", "sampling", "points", "PCL [ms]", "threads", "ours [ms]", "vs PCL"});
  // 0.1: the map file's voxel; 0.37: the automatic reduction voxel for this sweep (median
  // range / 20); 1.1: the front end's registered sample (3 voxels).
  for (const double voxel : {0.1, 0.37, 1.1}) {
    const auto leaf = static_cast<float>(voxel);
    Cloud out;
    pcl::VoxelGrid<pcl::PointXYZ> grid;
    grid.setInputCloud(sweep);
    grid.setLeafSize(leaf, leaf, leaf);
    const double t_grid = medianSeconds(opt.repeats, [&] { grid.filter(out); });
    pcl::UniformSampling<pcl::PointXYZ> uniform;
    uniform.setInputCloud(sweep);
    uniform.setRadiusSearch(voxel);
    const double t_uniform = medianSeconds(opt.repeats, [&] { uniform.filter(out); });
    using Sampling = Cloud::Ptr (*)(const Cloud&, double, unsigned);
    const auto row = [&](const char* name, double t_pcl, Sampling ours, unsigned t) {
      Cloud::Ptr sampled;
      const double t_ours =
          medianSeconds(opt.repeats, [&] { sampled = ours(*sweep, voxel, t); });
      table.addRow({fmt("%.2f", voxel),
                    name,
                    std::to_string(sampled->size()),
                    fmt("%.2f", 1e3 * t_pcl),
                    std::to_string(t),
                    fmt("%.2f", 1e3 * t_ours),
                    fmt("%.2fx", t_pcl / t_ours)});
    };
    for (const unsigned t : opt.threads) {
      row("centroid / `VoxelGrid`", t_grid, filters::voxelCentroid, t);
      row("nearest to centroid / `UniformSampling`",
          t_uniform,
          filters::voxelNearestToCentroid,
          t);
    }
  }
  table.print();
  std::printf("Machine check: a compute-bound OpenMP loop ran %.2fx faster on %u threads than "
              "on 1 before this table and %.2fx after it.\n\n",
              spin_before,
              max_threads,
              spinSpeedup(max_threads));
  return 0;
}

} // namespace bench
} // namespace pcl_parallel
