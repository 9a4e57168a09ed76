/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * parallelFor() (parallel.h) on both backends: the ranges, the slots, nesting, concurrent
 * callers and exceptions; and the default thread count's cgroup CPU limit.
 */
#include <pcl_parallel/parallel.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <mutex>
#include <sched.h>
#include <stdexcept>
#include <string>
#include <thread>
#include <unistd.h>
#include <utility>
#include <vector>

namespace {

using pcl_parallel::ParallelBackend;
using pcl_parallel::parallelFor;
using Range = std::pair<std::size_t, std::size_t>;

/** Runs the test body once per backend, restoring the default after. */
class ParallelFor : public ::testing::TestWithParam<ParallelBackend> {
protected:
  void
  SetUp() override
  {
    previous_ = pcl_parallel::parallelBackend();
    pcl_parallel::setParallelBackend(GetParam());
  }
  void
  TearDown() override
  {
    pcl_parallel::setParallelBackend(previous_);
  }
  ParallelBackend previous_ = ParallelBackend::kThreadPool;
};

std::vector<Range>
rangesOf(std::size_t n, unsigned threads, std::size_t grain)
{
  std::mutex m;
  std::vector<Range> got;
  parallelFor(n, threads, grain, [&](std::size_t begin, std::size_t end) {
    std::lock_guard<std::mutex> lock(m);
    got.emplace_back(begin, end);
  });
  std::sort(got.begin(), got.end());
  return got;
}

// With several threads the ranges are exactly the grain-sized cuts of [0, n), each once;
// with one thread (or n <= grain) one call sees [0, n); nothing for n = 0.
TEST_P(ParallelFor, RangesCoverEveryIndexOnce)
{
  for (const std::size_t n : {0ul, 1ul, 7ul, 64ul, 65ul, 1000ul, 100003ul})
    for (const std::size_t grain : {1ul, 3ul, 64ul, 4096ul})
      for (const unsigned threads : {1u, 2u, 3u, 8u}) {
        std::vector<Range> expected;
        if (n > 0 && (threads == 1 || n <= grain))
          expected.emplace_back(0, n);
        else
          for (std::size_t b = 0; b < n; b += grain)
            expected.emplace_back(b, std::min(n, b + grain));
        EXPECT_EQ(rangesOf(n, threads, grain), expected)
            << n << " items, grain " << grain << ", " << threads << " threads";
      }
}

// A slot is below the thread count and never held by two ranges at once: per-thread state
// indexed by it (the padded search slots, paper Sec. IV-B) is never shared.
TEST_P(ParallelFor, SlotsAreDistinctWhileRunning)
{
  for (const unsigned threads : {2u, 3u, 4u}) {
    std::vector<std::atomic<int>> held(threads);
    std::atomic<int> bad{0};
    std::atomic<unsigned> largest{0};
    parallelFor(400, threads, 1, [&](std::size_t, std::size_t, unsigned slot) {
      if (slot >= threads) {
        ++bad;
        return;
      }
      if (held[slot].exchange(1) != 0)
        ++bad;
      unsigned seen = largest.load();
      while (slot > seen && !largest.compare_exchange_weak(seen, slot)) {
      }
      // Hold the range until a second thread has taken one (bounded: 10 s).
      for (int i = 0; i < 20000 && largest.load() < 1; ++i)
        std::this_thread::sleep_for(std::chrono::microseconds(500));
      std::this_thread::sleep_for(std::chrono::microseconds(100)); // overlap the others
      held[slot].store(0);
    });
    EXPECT_EQ(bad.load(), 0) << threads << " threads";
    EXPECT_GE(largest.load(), 1u) << threads << " threads: the caller ran every range";
  }
}

// A parallelFor inside a body runs on the thread that calls it, in one range.
TEST_P(ParallelFor, NestedCallRunsInline)
{
  std::atomic<int> calls{0}, whole{0};
  parallelFor(16, 2, 1, [&](std::size_t, std::size_t) {
    parallelFor(100, 2, 1, [&](std::size_t begin, std::size_t end, unsigned slot) {
      ++calls;
      whole += begin == 0 && end == 100 && slot == 0;
    });
  });
  EXPECT_EQ(calls.load(), 16);
  EXPECT_EQ(whole.load(), 16);
}

// Two threads calling at once both get every index done exactly once.
TEST_P(ParallelFor, ConcurrentCallersEachCompleteTheirOwn)
{
  constexpr std::size_t n = 20000;
  std::vector<std::atomic<int>> a(n), b(n);
  const auto fill = [](std::vector<std::atomic<int>>& v) {
    for (int rep = 0; rep < 20; ++rep)
      parallelFor(n, 2, 97, [&](std::size_t begin, std::size_t end) {
        for (std::size_t i = begin; i < end; ++i)
          ++v[i];
      });
  };
  std::thread other([&] { fill(b); });
  fill(a);
  other.join();
  for (std::size_t i = 0; i < n; ++i) {
    ASSERT_EQ(a[i].load(), 20) << i;
    ASSERT_EQ(b[i].load(), 20) << i;
  }
}

// An exception leaves parallelFor with its message, and the next call works as before.
TEST_P(ParallelFor, ExceptionIsRethrownAndLaterCallsWork)
{
  EXPECT_THROW(
      {
        try {
          parallelFor(10000, 2, 1, [&](std::size_t begin, std::size_t) {
            if (begin == 3)
              throw std::runtime_error("range 3");
          });
        }
        catch (const std::runtime_error& e) {
          EXPECT_STREQ(e.what(), "range 3");
          throw;
        }
      },
      std::runtime_error);
  std::atomic<std::size_t> sum{0};
  parallelFor(1000, 2, 10, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      sum += i;
  });
  EXPECT_EQ(sum.load(), 999u * 1000u / 2u);
}

INSTANTIATE_TEST_SUITE_P(Backends,
                         ParallelFor,
                         ::testing::Values(ParallelBackend::kThreadPool,
                                           ParallelBackend::kOpenMP),
                         [](const auto& info) {
                           return info.param == ParallelBackend::kOpenMP ? "OpenMP" : "Pool";
                         });

/** A cgroup file tree under a temporary directory. */
class CgroupTree {
public:
  CgroupTree()
      : root_(std::filesystem::temp_directory_path() /
              ("pcl_parallel_cgroup_" + std::to_string(::getpid()) + "_" +
               std::to_string(counter_++)))
  {
    std::filesystem::create_directories(root_);
  }
  ~CgroupTree()
  {
    std::filesystem::remove_all(root_);
  }
  void
  write(const std::string& relative, const std::string& text) const
  {
    const std::filesystem::path p = root_ / relative;
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p) << text;
  }
  std::string
  root() const
  {
    return root_.string();
  }

private:
  static inline int counter_ = 0;
  std::filesystem::path root_;
};

using pcl_parallel::detail::cgroupCpuLimit;

TEST(CgroupCpuLimit, Version2QuotaOfTheCgroupOrATighterAncestor)
{
  CgroupTree t;
  t.write("user.slice/app/cpu.max", "150000 100000\n");
  t.write("user.slice/cpu.max", "max 100000\n");
  EXPECT_DOUBLE_EQ(cgroupCpuLimit("0::/user.slice/app\n", t.root()).value_or(-1), 1.5);
  t.write("user.slice/cpu.max", "50000 100000\n");
  EXPECT_DOUBLE_EQ(cgroupCpuLimit("0::/user.slice/app\n", t.root()).value_or(-1), 0.5);
}

TEST(CgroupCpuLimit, Version2WithoutQuotaOrFilesIsNone)
{
  CgroupTree t;
  t.write("a/cpu.max", "max 100000\n");
  EXPECT_FALSE(cgroupCpuLimit("0::/a\n", t.root()));
  EXPECT_FALSE(cgroupCpuLimit("0::/missing/deeper\n", t.root()));
  EXPECT_FALSE(cgroupCpuLimit("", t.root()));
  EXPECT_FALSE(cgroupCpuLimit("garbage without colons\n", t.root()));
  t.write("b/cpu.max", "-1 100000\n");
  EXPECT_FALSE(cgroupCpuLimit("0::/b\n", t.root()));
}

// Inside a container the cgroup namespace shows "/": the limit is the root's own.
TEST(CgroupCpuLimit, Version2InsideANamespaceReadsTheRoot)
{
  CgroupTree t;
  t.write("cpu.max", "200000 100000\n");
  EXPECT_DOUBLE_EQ(cgroupCpuLimit("0::/\n", t.root()).value_or(-1), 2.0);
}

TEST(CgroupCpuLimit, Version1CfsQuota)
{
  CgroupTree t;
  t.write("cpu,cpuacct/docker/abc/cpu.cfs_quota_us", "250000\n");
  t.write("cpu,cpuacct/docker/abc/cpu.cfs_period_us", "100000\n");
  const std::string proc = "12:memory:/docker/abc\n4:cpu,cpuacct:/docker/abc\n";
  EXPECT_DOUBLE_EQ(cgroupCpuLimit(proc, t.root()).value_or(-1), 2.5);
  t.write("cpu,cpuacct/docker/abc/cpu.cfs_quota_us", "-1\n");
  EXPECT_FALSE(cgroupCpuLimit(proc, t.root()));
  // The memory controller's line is not a CPU limit.
  EXPECT_FALSE(cgroupCpuLimit("12:memory:/docker/abc\n", t.root()));
}

// The default is at most the CPUs this process may run on.
TEST(HardwareThreads, AtMostTheAffinityMask)
{
  if (std::getenv("OMP_NUM_THREADS"))
    GTEST_SKIP() << "OMP_NUM_THREADS is set: it decides the default";
  cpu_set_t set;
  CPU_ZERO(&set);
  ASSERT_EQ(sched_getaffinity(0, sizeof(set), &set), 0);
  EXPECT_GE(pcl_parallel::hardwareThreads(), 1u);
  EXPECT_LE(pcl_parallel::hardwareThreads(), static_cast<unsigned>(CPU_COUNT(&set)));
}

} // namespace
