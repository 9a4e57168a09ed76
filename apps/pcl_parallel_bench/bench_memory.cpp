/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Memory benchmark (issue 11): the k-d tree's bytes per point beyond the cloud, and the
 * peak resident memory of ParallelIterativeClosestPoint on 1, 5 and 20 million points.
 * Each size runs in a child process (fork), so getrusage's ru_maxrss is that run's peak;
 * the clouds alone are measured first in the same child, so the table separates what
 * the input costs from what ICP adds.
 */
#include "bench_common.h"

#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/registration/icp.h>

#include <pcl/common/transforms.h>

#include <Eigen/Geometry>

#include <cstdio>
#include <random>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

namespace pcl_parallel {
namespace bench {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

double
peakMiB()
{
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_maxrss) / 1024.0; // Linux: kilobytes
}

Cloud::Ptr
uniform(std::size_t n, std::uint32_t seed)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-50.0f, 50.0f);
  Cloud::Ptr c(new Cloud);
  c->resize(n);
  for (auto& p : *c)
    p = pcl::PointXYZ(u(rng), u(rng), u(rng));
  return c;
}

/** Runs f in a child process; returns what it wrote (a line), "" on failure. */
template <typename F>
std::string
inChild(F&& f)
{
  int fd[2];
  if (pipe(fd) != 0)
    return "";
  const pid_t pid = fork();
  if (pid == 0) {
    close(fd[0]);
    const std::string line = f();
    if (write(fd[1], line.data(), line.size()) < 0)
      _exit(1);
    _exit(0);
  }
  close(fd[1]);
  char buf[512];
  std::string out;
  for (ssize_t k; (k = read(fd[0], buf, sizeof buf)) > 0;)
    out.append(buf, static_cast<std::size_t>(k));
  close(fd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) && WEXITSTATUS(status) == 0 ? out : "";
}

} // namespace

int
runMemory(const Options& opt)
{
  const unsigned threads = opt.threads.back();
  // ICP first: the children are forked before this process starts OpenMP threads
  // (libgomp's pool does not survive a fork).
  std::printf("### ParallelIterativeClosestPoint peak resident memory (%u threads, "
              "3 iterations)\n\n",
              threads);
  std::printf("| points | clouds (source + target + output) MiB | peak MiB | ICP adds MiB | "
              "ICP adds bytes / point | seconds |\n|---|---|---|---|---|---|\n");
  for (std::size_t millions : {1ul, 5ul, 20ul}) {
    const std::string line = inChild([&] {
      const std::size_t n = millions * 1000000;
      const Cloud::Ptr src = uniform(n, 2);
      Eigen::Affine3f motion(Eigen::AngleAxisf(0.01f, Eigen::Vector3f::UnitZ()));
      motion.translation() << 0.05f, -0.02f, 0.01f;
      Cloud::Ptr tgt(new Cloud);
      pcl::transformPointCloud(*src, *tgt, motion);
      Cloud out;
      out.resize(n); // the output cloud align() fills, allocated up front
      const double clouds = peakMiB();
      registration::ParallelIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
      icp.setNumberOfThreads(threads);
      icp.setMaxCorrespondenceDistance(0.5);
      icp.setMaximumIterations(3);
      icp.setInputSource(src);
      icp.setInputTarget(tgt);
      const auto start = std::chrono::steady_clock::now();
      icp.align(out);
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const double peak = peakMiB();
      return fmt("| %zu M | %.0f | %.0f | %.0f | %.1f | %.1f |\n",
                 millions,
                 clouds,
                 peak,
                 peak - clouds,
                 (peak - clouds) * 1048576.0 / static_cast<double>(n),
                 seconds);
    });
    std::printf("%s", line.empty() ? "| failed (out of memory?) |\n" : line.c_str());
    std::fflush(stdout);
  }
  std::printf("\n### k-d tree memory beyond the cloud (bucket %u)\n\n",
              KdTreeIndex::kDefaultBucketSize);
  std::printf("| points | nodes | tree bytes | bytes / point |\n|---|---|---|---|\n");
  for (std::size_t n : {100000ul, 1000000ul, 5000000ul}) {
    const Cloud::Ptr c = uniform(n, 1);
    KdTreeIndex tree;
    tree.build(c->front().data, c->size(), 4, nullptr, threads);
    std::printf("| %zu | %zu | %zu | %.2f |\n",
                n,
                tree.numNodes(),
                tree.memoryBytes(),
                static_cast<double>(tree.memoryBytes()) / static_cast<double>(n));
  }

  return 0;
}

} // namespace bench
} // namespace pcl_parallel
