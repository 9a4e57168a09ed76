/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pLUM over MPI ranks on the Stanford bunny (docs/benchmarks.md, "MPI"):
 *   mpirun -np R pcl_parallel_mpi_bench [threads per rank] [iterations]
 * The mapping pipeline over MPI ranks (mpi::mapSegments) on a simulated preset:
 *   mpirun -np R pcl_parallel_mpi_bench pslam PRESET [threads per rank] [segments]
 * segments 0 (one rank only): the one-process pipeline (slam::Pipeline::addScan), the
 * baseline. Prints rank 0's times per stage, the bytes sent, each rank's peak memory and
 * the errors against the truth.
 * The case of "LUM: Stanford bunny, whole pLUM relaxation" (paper mode): start poses =
 * bun.conf perturbed by 2 deg / 3 mm (seed 2007), links >= 30% overlap at the start poses,
 * every 4th point queried, gate max(2 mm, 10 mm * 0.9^k). Prints rank 0's times, the bytes
 * sent per iteration and each rank's scans and peak memory.
 */
#include "../pcl_parallel_bench/preset_reader.h"
#include "synthetic_graph.h"

#include <pcl_parallel/evaluation/trajectory_error.h>
#include <pcl_parallel/io/stanford.h>
#include <pcl_parallel/mpi/distributed_lum.h>
#include <pcl_parallel/mpi/pipeline.h>
#include <pcl_parallel/sim/presets.h>
#include <pcl_parallel/sim/scan_set_writer.h>

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

/** Peak resident memory of every rank, gathered on rank 0 (MiB). */
std::vector<double>
peakMiB(int size)
{
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const long peak_kib = usage.ru_maxrss;
  std::vector<long> peaks(size);
  MPI_Gather(&peak_kib, 1, MPI_LONG, peaks.data(), 1, MPI_LONG, 0, MPI_COMM_WORLD);
  std::vector<double> mib;
  for (long p : peaks)
    mib.push_back(p / 1024.0);
  return mib;
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

  const auto peaks = peakMiB(size);
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
                  peaks[r],
                  r == 0 ? " (incl. choosing the links from all scans)" : "");
    std::printf("pose 9 translation: %.9f %.9f %.9f\n",
                d.getPoseMatrix(9)(0, 3),
                d.getPoseMatrix(9)(1, 3),
                d.getPoseMatrix(9)(2, 3));
  }
  return 0;
}

int
runPslam(int argc, char** argv)
{
  namespace slam = pcl_parallel::slam;
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  if (argc < 2)
    throw std::invalid_argument("usage: pslam PRESET [threads per rank] [segments]");
  const std::string preset = argv[1];
  const unsigned threads = argc > 2 ? static_cast<unsigned>(std::atoi(argv[2])) : 1;
  const std::size_t segments = argc > 3 ? std::strtoul(argv[3], nullptr, 10) : size;
  if (segments == 0 && size > 1)
    throw std::invalid_argument("segments 0 (one front end) needs one rank");
  // The preset, written once by rank 0 (as `pcl_pslam simulate` writes it).
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("pcl_parallel_mpi_bench_" + preset);
  // Simulated once, in a run of its own: the simulation's memory is not the pipeline's.
  int simulated = 0;
  if (rank == 0 && !std::filesystem::exists(dir / "ground_truth.txt")) {
    std::printf("simulating %s into %s; run again to measure\n", preset.c_str(), dir.c_str());
    pcl_parallel::sim::writeScanSet(pcl_parallel::sim::simulatePreset(preset, 1u, 0u),
                                    dir.string());
    simulated = 1;
  }
  MPI_Bcast(&simulated, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (simulated)
    return 0;
  const bool uos = std::filesystem::exists(dir / "scan000.3d");
  const pcl_parallel::bench::PresetReader reader(dir.string(), uos);
  const auto truth = pcl_parallel::io::loadKittiPoses((dir / "ground_truth.txt").string());
  const std::size_t n = truth.size();

  slam::Parameters p;
  p.num_threads = threads;
  p.deskew.enabled = !reader.uos;
  double read_seconds = 0.0;
  const slam::ScanSource read = [&](std::size_t i) {
    const double t = now();
    Eigen::Matrix4d odometry;
    auto scan = reader.scan(i, odometry);
    read_seconds += now() - t;
    return slam::SourceScan{scan, odometry, std::nullopt, {}};
  };
  pcl_parallel::mpi::SegmentsReport report;
  MPI_Barrier(MPI_COMM_WORLD);
  const double t0 = now();
  std::unique_ptr<slam::Pipeline> pipeline;
  if (segments == 0) {
    pipeline.reset(new slam::Pipeline(p));
    for (std::size_t i = 0; i < n; ++i) {
      const slam::SourceScan s = read(i);
      pipeline->addScan(*s.cloud, s.odometry);
    }
  }
  else
    pipeline = pcl_parallel::mpi::mapSegments(
        MPI_COMM_WORLD, p, n, (n + segments - 1) / segments, 5, read, &report);
  const double t1 = now();
  pipeline->finish();
  MPI_Barrier(MPI_COMM_WORLD);
  const double t2 = now();
  const auto peaks = peakMiB(size);
  // What each rank keeps of the graph: scans and bytes (points, trees, normals).
  unsigned long kept[2] = {pipeline->keptScans(), pipeline->bytesPerScan() * n};
  std::vector<unsigned long> kepts(2 * static_cast<std::size_t>(size));
  MPI_Gather(kept, 2, MPI_UNSIGNED_LONG, kepts.data(), 2, MPI_UNSIGNED_LONG, 0, MPI_COMM_WORLD);
  if (rank != 0)
    return 0;
  std::size_t loops = 0;
  for (const auto& l : pipeline->links())
    loops += l.loop ? 1 : 0;
  using pcl_parallel::evaluation::Alignment;
  const auto ate = [&](const slam::Poses& poses) {
    return pcl_parallel::evaluation::absoluteTrajectoryError(poses, truth, Alignment::SE3)
               .translation.rmse *
           100.0;
  };
  const auto& st = pipeline->times();
  std::printf("%s: %zu scans, %d ranks x %u threads, %zu segments: total %.2f s (%.1f scans/s)"
              "; rank 0: read %.2f s, front end %.2f s + %.2f s waiting, loop detection %.2f "
              "s, loop closing %.2f s (%d pLUM runs, finish %.2f s)\n",
              preset.c_str(),
              n,
              size,
              threads,
              segments,
              t2 - t0,
              n / (t2 - t0),
              read_seconds,
              st.preprocess + st.front_end,
              report.wait_seconds,
              st.loop_detection,
              st.loop_closing,
              pipeline->relaxations(),
              t2 - t1);
  std::printf("  ATE front end %.2f cm, final %.2f cm; %zu loop links; sent outside pLUM "
              "%.2f MB (%zu scans point to point); pLUM sends %.1f kB per iteration\n",
              ate(pipeline->frontEndPoses()),
              ate(pipeline->poses()),
              loops,
              report.bytes_shared / 1e6,
              report.scans_sent,
              report.lum_bytes_per_iteration / 1e3);
  const std::size_t segment_size = segments ? (n + segments - 1) / segments : n;
  for (int r = 0; r < size; ++r) {
    const auto [begin, end] = pcl_parallel::mpi::scansOfRank(n, segment_size, r, size);
    std::printf("  rank %d: scans %zu-%zu, keeps %lu scans (%.1f MB), peak RSS %.0f MiB\n",
                r,
                begin,
                end,
                kepts[2 * r],
                kepts[2 * r + 1] / 1e6,
                peaks[r]);
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
    rc = argc > 1 && std::string(argv[1]) == "pslam" ? runPslam(argc - 1, argv + 1)
                                                     : run(argc, argv);
  }
  catch (const std::exception& e) {
    std::fprintf(stderr, "pcl_parallel_mpi_bench: %s\n", e.what());
  }
  MPI_Finalize();
  return rc;
}
