/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pLUM over MPI ranks on the Stanford bunny (docs/benchmarks.md, "MPI"):
 *   mpirun -np R pcl_parallel_mpi_bench [threads per rank] [iterations]
 * The case of "LUM: Stanford bunny, whole pLUM relaxation" (paper mode): start poses =
 * bun.conf perturbed by 2 deg / 3 mm (seed 2007), links >= 30% overlap at the start poses,
 * every 4th point queried, gate max(2 mm, 10 mm * 0.9^k). Prints rank 0's times, the bytes
 * sent per iteration and each rank's scans and peak memory.
 */
#include "synthetic_graph.h"

#include <pcl_parallel/io/stanford.h>
#include <pcl_parallel/mpi/distributed_lum.h>

#include <pcl/console/print.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <sys/resource.h>

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

double
now()
{
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

int
run(int argc, char** argv)
{
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  const unsigned threads = argc > 1 ? static_cast<unsigned>(std::atoi(argv[1])) : 1;
  const int iterations = argc > 2 ? std::atoi(argv[2]) : 50;
  const char* env = std::getenv("PCL_PARALLEL_DATA_DIR");
  const std::filesystem::path dir =
      std::filesystem::path(env ? env : PCL_PARALLEL_DATA_DIR) / "stanford_bunny";
  const auto entries = pcl_parallel::io::loadStanfordConf((dir / "bun.conf").string());
  std::vector<Eigen::Matrix4d> start;
  std::mt19937 rng(2007);
  for (const auto& e : entries)
    start.push_back(start.empty()
                        ? e.pose
                        : pcl_parallel::test::perturb(e.pose, 2.0 * M_PI / 180.0, 0.003, rng));
  // Links chosen at the start poses by rank 0 (reads every scan once), then broadcast.
  std::vector<std::uint64_t> flat;
  if (rank == 0) {
    pcl_parallel::ParallelLUM<pcl::PointXYZ> lum;
    for (std::size_t v = 0; v < entries.size(); ++v)
      lum.addPointCloud(pcl_parallel::io::loadStanfordScan((dir / entries[v].file).string()),
                        Eigen::Matrix4f::Identity());
    for (std::size_t v = 0; v < entries.size(); ++v)
      lum.setPoseMatrix(v, start[v]);
    for (const auto& [i, j] : lum.findOverlappingPairs(0.01, 0.3)) {
      flat.push_back(i);
      flat.push_back(j);
    }
  }
  int count = static_cast<int>(flat.size());
  MPI_Bcast(&count, 1, MPI_INT, 0, MPI_COMM_WORLD);
  flat.resize(static_cast<std::size_t>(count));
  MPI_Bcast(flat.data(), count, MPI_UINT64_T, 0, MPI_COMM_WORLD);
  std::vector<std::pair<std::size_t, std::size_t>> links;
  for (std::size_t k = 0; k < flat.size(); k += 2)
    links.emplace_back(flat[k], flat[k + 1]);

  pcl_parallel::mpi::DistributedLUM<pcl::PointXYZ> d;
  d.lum().setNumberOfThreads(threads);
  d.lum().setQueryStep(4);
  d.lum().setCorrespondenceDistanceSchedule(0.01, 0.002, 0.9);
  d.lum().setMaxIterations(iterations);
  MPI_Barrier(MPI_COMM_WORLD);
  const double t0 = now();
  d.setGraph(start, links, [&](std::size_t v) {
    return pcl_parallel::io::loadStanfordScan((dir / entries[v].file).string());
  });
  MPI_Barrier(MPI_COMM_WORLD);
  const double t1 = now();
  d.compute(); // includes the trees of this rank's scans
  MPI_Barrier(MPI_COMM_WORLD);
  const double t2 = now();

  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const long peak_kib = usage.ru_maxrss;
  std::vector<long> peaks(size);
  MPI_Gather(&peak_kib, 1, MPI_LONG, peaks.data(), 1, MPI_LONG, 0, MPI_COMM_WORLD);
  const int loaded = static_cast<int>(d.getLoadedVertices().size());
  std::vector<int> loads(size);
  MPI_Gather(&loaded, 1, MPI_INT, loads.data(), 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (rank == 0) {
    std::printf("ranks %d x threads %u: %zu links, %d iterations, load %.2f s, compute "
                "%.2f s (%.3f s/iteration), %llu bytes sent per iteration\n",
                size,
                threads,
                links.size(),
                d.lum().getNumIterationsDone(),
                t1 - t0,
                t2 - t1,
                (t2 - t1) / std::max(1, d.lum().getNumIterationsDone()),
                static_cast<unsigned long long>(d.getBytesPerIteration()));
    for (int r = 0; r < size; ++r)
      std::printf("  rank %d: %d scans, peak RSS %.0f MiB%s\n",
                  r,
                  loads[r],
                  peaks[r] / 1024.0,
                  r == 0 ? " (incl. choosing the links from all scans)" : "");
    std::printf("pose 9 translation: %.9f %.9f %.9f\n",
                d.getPoseMatrix(9)(0, 3),
                d.getPoseMatrix(9)(1, 3),
                d.getPoseMatrix(9)(2, 3));
  }
  return 0;
}

} // namespace

int
main(int argc, char** argv)
{
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
  int rc = 1;
  try {
    rc = run(argc, argv);
  }
  catch (const std::exception& e) {
    std::fprintf(stderr, "pcl_parallel_mpi_bench: %s\n", e.what());
  }
  MPI_Finalize();
  return rc;
}
