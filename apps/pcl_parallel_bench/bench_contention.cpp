/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * "contention": each workload at 1 and N threads on an idle machine, beside one CPU-bound
 * process pinned to one core, and beside a CPU-bound job of N threads, all started by this
 * benchmark; on the library's pool and on OpenMP's runtime, side by side in one run. On a
 * busy machine more threads must never be slower than one (docs/design.md, "Threads").
 */
#include "bench_common.h"

#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/stanford.h>
#include <pcl_parallel/io/uos.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/registration/icp.h>
#include <pcl_parallel/registration/lum.h>
#include <pcl_parallel/sim/presets.h>
#include <pcl_parallel/slam/pipeline.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <random>
#include <sched.h>
#include <signal.h>
#include <string>
#include <sys/wait.h>
#include <unistd.h>
#include <vector>

namespace pcl_parallel {
namespace bench {

namespace {

namespace fs = std::filesystem;
using Cloud = pcl::PointCloud<pcl::PointXYZ>;

struct Workload {
  std::string name;
  std::function<void(unsigned threads)> run;
};

/** CPU-bound processes started by the benchmark, killed when it goes out of scope. */
class Load {
public:
  /** \a processes spinning children; pinned to the last CPU of this process's mask when
   *  \a pinned, free to run anywhere otherwise. */
  Load(int processes, bool pinned)
  {
    cpu_set_t mine;
    CPU_ZERO(&mine);
    sched_getaffinity(0, sizeof(mine), &mine);
    int last = 0;
    for (int c = 0; c < CPU_SETSIZE; ++c)
      if (CPU_ISSET(c, &mine))
        last = c;
    for (int k = 0; k < processes; ++k) {
      const pid_t pid = fork();
      if (pid == 0) {
        if (pinned) {
          cpu_set_t one;
          CPU_ZERO(&one);
          CPU_SET(last, &one);
          sched_setaffinity(0, sizeof(one), &one);
        }
        volatile unsigned long x = 0;
        for (;;)
          x = x + 1;
      }
      if (pid > 0)
        children_.push_back(pid);
    }
  }
  ~Load()
  {
    for (const pid_t pid : children_) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
    }
  }
  Load(const Load&) = delete;
  Load&
  operator=(const Load&) = delete;

private:
  std::vector<pid_t> children_;
};

std::vector<Workload>
icpWorkloads(const Options& opt)
{
  std::vector<Workload> out;
  const auto add = [&](std::string name,
                       Cloud::Ptr src,
                       Cloud::Ptr tgt,
                       Eigen::Matrix4f guess,
                       double max_distance) {
    out.push_back({std::move(name), [=](unsigned threads) {
                     ParallelIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
                     icp.setNumberOfThreads(threads);
                     icp.setMaxCorrespondenceDistance(max_distance);
                     icp.setMaximumIterations(50);
                     icp.setInputSource(src);
                     icp.setInputTarget(tgt);
                     Cloud aligned;
                     icp.align(aligned, guess);
                   }});
  };
  const std::string dtk = opt.data_dir + "/3dtk_dat";
  if (fs::exists(dtk + "/scan001.3d"))
    add("pICP 3dtk scan001->scan000",
        io::loadUosScan(dtk + "/scan001.3d", 50, 3000),
        io::loadUosScan(dtk + "/scan000.3d", 50, 3000),
        (io::loadUosPose(dtk + "/scan000.pose").inverse() *
         io::loadUosPose(dtk + "/scan001.pose"))
            .cast<float>(),
        25.0);
  const std::string kitti = opt.data_dir + "/kitti_mini_dev/00/velodyne";
  if (fs::exists(kitti + "/000001.bin"))
    add("pICP kitti 00 sweep 1->0",
        io::loadKittiScan(kitti + "/000001.bin"),
        io::loadKittiScan(kitti + "/000000.bin"),
        Eigen::Matrix4f::Identity(),
        1.0);
  return out;
}

/** pLUM on the Stanford bunny's 10 scans: bun.conf perturbed by 2 deg / 3 mm, every pair
 *  a link, pairs within 5 mm, 3 iterations. */
std::vector<Workload>
lumWorkloads(const Options& opt)
{
  const std::string conf = opt.data_dir + "/stanford_bunny/bun.conf";
  if (!fs::exists(conf))
    return {};
  auto clouds = std::make_shared<std::vector<Cloud::Ptr>>();
  auto start = std::make_shared<std::vector<Eigen::Matrix4d>>();
  std::mt19937 rng(2007);
  std::normal_distribution<double> g(0.0, 1.0);
  for (const auto& e : io::loadStanfordConf(conf)) {
    clouds->push_back(io::loadStanfordScan((fs::path(conf).parent_path() / e.file).string()));
    Eigen::Matrix4d p = e.pose;
    if (!start->empty()) {
      const Eigen::Vector3d axis = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
      p.topLeftCorner<3, 3>() = Eigen::AngleAxisd(2.0 * M_PI / 180.0, axis).toRotationMatrix() *
                                p.topLeftCorner<3, 3>();
      p.topRightCorner<3, 1>() += 0.003 * Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    }
    start->push_back(p);
  }
  return {{"pLUM bunny, 10 scans, 3 iterations", [=](unsigned threads) {
             ParallelLUM<pcl::PointXYZ> lum;
             lum.setNumberOfThreads(threads);
             for (std::size_t v = 0; v < clouds->size(); ++v)
               lum.addPointCloud((*clouds)[v], Eigen::Matrix4f((*start)[v].cast<float>()));
             for (std::size_t i = 0; i < clouds->size(); ++i)
               for (std::size_t j = i + 1; j < clouds->size(); ++j)
                 lum.addLink(i, j);
             lum.setCorrespondenceDistance(0.005);
             lum.setMaxIterations(3);
             lum.compute();
           }}};
}

/** slam::Pipeline over scans held in memory, \a odometry per scan or none. */
Workload
pipelineWorkload(std::string name,
                 std::shared_ptr<std::vector<Cloud::Ptr>> scans,
                 std::shared_ptr<std::vector<Eigen::Matrix4d>> odometry,
                 slam::Parameters p)
{
  return {std::move(name), [=](unsigned threads) {
            slam::Parameters q = p;
            q.num_threads = threads;
            slam::Pipeline pipeline(q);
            for (std::size_t i = 0; i < scans->size(); ++i)
              pipeline.addScan(*(*scans)[i],
                               odometry->empty()
                                   ? std::nullopt
                                   : std::optional<Eigen::Matrix4d>((*odometry)[i]));
            pipeline.finish();
          }};
}

std::vector<Workload>
pipelineWorkloads(const Options& opt)
{
  std::vector<Workload> out;
  {
    const auto set = sim::simulatePreset("office", 1u, 0u);
    auto scans = std::make_shared<std::vector<Cloud::Ptr>>(set.scans.begin(), set.scans.end());
    auto odometry = std::make_shared<std::vector<Eigen::Matrix4d>>(set.odometry);
    out.push_back(pipelineWorkload(
        "pipeline: office preset (11 scans, odometry)", scans, odometry, slam::Parameters{}));
  }
  const fs::path bin = fs::path(opt.data_dir) / "fastlio_quick_shack" / "bin";
  if (fs::exists(bin)) {
    std::vector<std::string> files;
    for (const auto& e : fs::directory_iterator(bin))
      if (e.path().extension() == ".bin")
        files.push_back(e.path().string());
    std::sort(files.begin(), files.end());
    auto scans = std::make_shared<std::vector<Cloud::Ptr>>();
    for (const auto& f : files)
      scans->push_back(io::loadKittiScan(f));
    slam::Parameters p;
    p.loops.enabled = false;
    out.push_back(pipelineWorkload(
        fmt("pipeline: fastlio keyframes (%zu, no odometry, no loops)", scans->size()),
        scans,
        std::make_shared<std::vector<Eigen::Matrix4d>>(),
        p));
  }
  return out;
}

double
median(std::vector<double> v)
{
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

/** \a w at 1 and \a n threads on \a backend, the two alternating (after one warm-up
 *  each) so that the machine's drift falls on both: the median of each, and the median
 *  of the pairs' ratios n / 1. */
struct Pair {
  double one, many, ratio;
};
Pair
timePair(const Workload& w, unsigned n, ParallelBackend backend, int repeats)
{
  setParallelBackend(backend);
  w.run(1);
  w.run(n);
  std::vector<double> one, many, ratio;
  for (int r = 0; r < std::max(1, repeats); ++r) {
    one.push_back(seconds([&] { w.run(1); }));
    many.push_back(seconds([&] { w.run(n); }));
    ratio.push_back(many.back() / one.back());
  }
  setParallelBackend(ParallelBackend::kThreadPool);
  return {median(one), median(many), median(ratio)};
}

} // namespace

int
runContention(const Options& opt)
{
  const unsigned n = *std::max_element(opt.threads.begin(), opt.threads.end());
  if (n < 2) {
    std::printf("contention: needs a thread count above 1 (--threads 1,N)\n");
    return 2;
  }
  std::vector<Workload> workloads = icpWorkloads(opt);
  for (auto* more : {&lumWorkloads, &pipelineWorkloads})
    for (auto& w : (*more)(opt))
      workloads.push_back(std::move(w));

  std::printf("### Contention: 1 vs %u threads, idle and beside CPU-bound processes\n\n", n);
  std::printf("1 and %u threads alternating, %d runs each after a warm-up: medians, and the "
              "median of the pairs' ratios. 'one busy core': one spinning process "
              "pinned to one of this process's CPUs; 'all cores busy': %u spinning processes, "
              "unpinned. Pool: the library's threads (default); OpenMP: the same loops on "
              "libgomp (PCL_PARALLEL_BACKEND=openmp), without OMP_WAIT_POLICY. Ratio = %u "
              "threads / 1 thread in the same conditions (below 1: faster).\n\n",
              n,
              opt.repeats,
              n,
              n);
  std::printf("Machine check: a compute-bound loop ran %.2fx faster on %u threads than on 1 "
              "(idle).\n\n",
              spinSpeedup(n),
              n);
  struct Condition {
    const char* name;
    int processes;
    bool pinned;
  };
  const Condition conditions[] = {{"idle", 0, false},
                                  {"one busy core", 1, true},
                                  {"all cores busy", static_cast<int>(n), false}};
  Table t({"workload",
           "backend",
           "idle 1 [s]",
           fmt("idle %u [s]", n),
           "ratio",
           "one busy core 1 [s]",
           fmt("one busy core %u [s]", n),
           "ratio",
           "all busy 1 [s]",
           fmt("all busy %u [s]", n),
           "ratio"});
  for (const Workload& w : workloads) {
    for (const ParallelBackend b : {ParallelBackend::kThreadPool, ParallelBackend::kOpenMP}) {
      std::vector<std::string> row{w.name, b == ParallelBackend::kOpenMP ? "OpenMP" : "pool"};
      for (const Condition& c : conditions) {
        const Load load(c.processes, c.pinned);
        const Pair p = timePair(w, n, b, opt.repeats);
        row.push_back(fmt("%.3f", p.one));
        row.push_back(fmt("%.3f", p.many));
        row.push_back(fmt("%.2f", p.ratio));
      }
      t.addRow(row);
      std::fprintf(stderr, "contention: %s (%s) done\n", w.name.c_str(), row[1].c_str());
    }
  }
  t.print();
  return 0;
}

} // namespace bench
} // namespace pcl_parallel
