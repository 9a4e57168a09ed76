/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "backends.h"

#include <pcl/console/print.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sched.h>
#include <sstream>
#include <thread>
#include <vector>

namespace pcl_parallel {

namespace {

/** The first number of OMP_NUM_THREADS ("4" or "4,2"), 0 when unset or not a number. */
unsigned
threadsFromEnvironment()
{
  const char* text = std::getenv("OMP_NUM_THREADS");
  if (!text)
    return 0;
  char* end = nullptr;
  const long value = std::strtol(text, &end, 10);
  if (end == text || value < 1)
    return 0;
  return static_cast<unsigned>(std::min<long>(value, kMaxThreads));
}

unsigned
affinityCpus()
{
  // CPU_ALLOC: the mask of a machine with more than 1024 CPUs does not fit cpu_set_t.
  for (int cpus = 1024; cpus <= (1 << 20); cpus *= 4) {
    cpu_set_t* set = CPU_ALLOC(cpus);
    const std::size_t size = CPU_ALLOC_SIZE(cpus);
    CPU_ZERO_S(size, set);
    const int rc = sched_getaffinity(0, size, set);
    const int count = rc == 0 ? CPU_COUNT_S(size, set) : 0;
    CPU_FREE(set);
    if (rc == 0)
      return static_cast<unsigned>(std::max(count, 1));
    if (errno != EINVAL)
      break;
  }
  return std::max(1u, std::thread::hardware_concurrency());
}

std::string
readText(const std::string& path)
{
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return in ? text.str() : std::string();
}

/** quota / period from a v2 cpu.max ("max 100000" or "150000 100000"). */
std::optional<double>
cpuMax(const std::string& text)
{
  std::istringstream in(text);
  std::string quota;
  double period = 0.0;
  if (!(in >> quota >> period) || quota == "max" || !(period > 0.0))
    return std::nullopt;
  char* end = nullptr;
  const double q = std::strtod(quota.c_str(), &end);
  if (end == quota.c_str() || !(q > 0.0))
    return std::nullopt;
  return q / period;
}

/** quota / period from v1's cpu.cfs_quota_us (-1: none) and cpu.cfs_period_us. */
std::optional<double>
cfsQuota(const std::string& dir)
{
  const std::string quota = readText(dir + "/cpu.cfs_quota_us");
  const std::string period = readText(dir + "/cpu.cfs_period_us");
  if (quota.empty() || period.empty())
    return std::nullopt;
  const double q = std::strtod(quota.c_str(), nullptr);
  const double p = std::strtod(period.c_str(), nullptr);
  if (!(q > 0.0) || !(p > 0.0))
    return std::nullopt;
  return q / p;
}

/** best becomes \a limit where that is set and tighter. */
void
keepTighter(std::optional<double>& best, const std::optional<double>& limit)
{
  if (limit && (!best || *limit < *best))
    best = limit;
}

/** The tightest limit read by \a limit_in over \a dir and its parents up to \a root. */
template <typename Read>
std::optional<double>
tightestUpTo(const std::string& root, std::string path, Read&& limit_in)
{
  std::optional<double> best;
  for (;;) {
    keepTighter(best, limit_in(root + path));
    if (path.empty() || path == "/")
      return best;
    const std::size_t slash = path.find_last_of('/');
    path = slash == std::string::npos || slash == 0 ? std::string() : path.substr(0, slash);
  }
}

bool
hasController(const std::string& controllers, const std::string& name)
{
  std::istringstream in(controllers);
  std::string c;
  while (std::getline(in, c, ','))
    if (c == name)
      return true;
  return false;
}

ParallelBackend
backendFromEnvironment()
{
  const char* text = std::getenv("PCL_PARALLEL_BACKEND");
  return text && std::strcmp(text, "openmp") == 0 ? ParallelBackend::kOpenMP
                                                  : ParallelBackend::kThreadPool;
}

std::atomic<ParallelBackend>&
backend()
{
  static std::atomic<ParallelBackend> b{backendFromEnvironment()};
  return b;
}

} // namespace

namespace detail {

std::optional<double>
cgroupCpuLimit(const std::string& proc_cgroup, const std::string& cgroup_root)
{
  std::optional<double> best;
  std::istringstream lines(proc_cgroup);
  std::string line;
  while (std::getline(lines, line)) {
    // "hierarchy-id:controllers:path"; v2 is "0::path".
    const std::size_t a = line.find(':'),
                      b = a == std::string::npos ? a : line.find(':', a + 1);
    if (b == std::string::npos)
      continue;
    const std::string id = line.substr(0, a), controllers = line.substr(a + 1, b - a - 1);
    const std::string path = line.substr(b + 1);
    if (id == "0" && controllers.empty())
      keepTighter(best, tightestUpTo(cgroup_root, path, [](const std::string& dir) {
                    return cpuMax(readText(dir + "/cpu.max"));
                  }));
    else if (hasController(controllers, "cpu"))
      for (const char* mount : {"/cpu,cpuacct", "/cpuacct,cpu", "/cpu"})
        keepTighter(best, tightestUpTo(cgroup_root + mount, path, cfsQuota));
  }
  return best;
}

void
parallelRanges(std::size_t n, std::size_t grain, unsigned threads, RangeFunction f, void* body)
{
  if (parallelBackend() == ParallelBackend::kOpenMP)
    runOnOpenMP(n, grain, threads, f, body);
  else
    runOnPool(n, grain, threads, f, body);
}

} // namespace detail

unsigned
hardwareThreads()
{
  static const unsigned threads = [] {
    if (const unsigned requested = threadsFromEnvironment())
      return requested;
    unsigned cpus = std::min(affinityCpus(), kMaxThreads);
    const std::optional<double> limit =
        detail::cgroupCpuLimit(readText("/proc/self/cgroup"), "/sys/fs/cgroup");
    if (limit)
      cpus = std::min(cpus, static_cast<unsigned>(std::max(1.0, std::floor(*limit))));
    return cpus;
  }();
  return threads;
}

unsigned
resolveNumberOfThreads(unsigned requested)
{
  if (requested == 0)
    return hardwareThreads();
  if (requested > kMaxThreads) {
    PCL_WARN("[pcl_parallel] %u threads requested; using %u (the most pcl_parallel "
             "accepts).\n",
             requested,
             kMaxThreads);
    return kMaxThreads;
  }
  return requested;
}

void
setParallelBackend(ParallelBackend b)
{
  backend().store(b, std::memory_order_relaxed);
}

ParallelBackend
parallelBackend()
{
  return backend().load(std::memory_order_relaxed);
}

} // namespace pcl_parallel
