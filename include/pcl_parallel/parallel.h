/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>

namespace pcl_parallel {

/** Size the per-thread search state is padded to (paper Sec. IV-B): one x86-64 cache
 *  line. A constant, not std::hardware_destructive_interference_size, so the ABI does not
 *  depend on compiler flags. */
constexpr std::size_t kCacheLineSize = 64;

/** Largest thread count accepted; larger requests (e.g. a negative int cast to
 *  unsigned) are clamped with a warning instead of allocating state for billions of
 *  threads. */
constexpr unsigned kMaxThreads = 1024;

/** Resolves a user's thread request: 0 means hardwareThreads(), anything above kMaxThreads
 *  is clamped (with a PCL_WARN). Always returns >= 1. */
unsigned
resolveNumberOfThreads(unsigned requested);

/** The threads this process may run at once, the default thread count: OMP_NUM_THREADS
 *  when set, else the CPUs of its affinity mask, capped by its cgroup's CPU quota rounded
 *  down (a container limited to 1.5 CPUs gets 1 thread). Read once. */
unsigned
hardwareThreads();

/** What runs parallelFor(): the library's own pool (default) or OpenMP's runtime. */
enum class ParallelBackend {
  kThreadPool, ///< callers never wait for a worker that has not started (docs/design.md)
  kOpenMP      ///< `omp parallel for schedule(dynamic)`: every thread meets at the end
};

/** Selects the backend for all later parallelFor() calls in the process (thread-safe).
 *  The default is kThreadPool, or kOpenMP when PCL_PARALLEL_BACKEND=openmp is set. */
void
setParallelBackend(ParallelBackend backend);

/** The backend parallelFor() uses now. */
ParallelBackend
parallelBackend();

namespace detail {

using RangeFunction = void (*)(void* body, std::size_t begin, std::size_t end, unsigned slot);

/** Type-erased parallelFor(); \a threads already resolved (>= 2) and n > grain. */
void
parallelRanges(std::size_t n, std::size_t grain, unsigned threads, RangeFunction f, void* body);

/** CPU limit of the cgroup a process is in: \a proc_cgroup is the text of
 *  /proc/self/cgroup, \a cgroup_root where the cgroup file systems are mounted
 *  (/sys/fs/cgroup). The tightest quota / period of the process's cgroup and its
 *  ancestors (v2 cpu.max, v1 cpu.cfs_quota_us and cpu.cfs_period_us); nullopt when none
 *  is set or nothing is readable. */
std::optional<double>
cgroupCpuLimit(const std::string& proc_cgroup, const std::string& cgroup_root);

} // namespace detail

/**
 * \brief Runs `body(begin, end)` or `body(begin, end, slot)` over ranges that together
 * cover [0, n) exactly once, on up to \a num_threads threads (0: hardwareThreads()); the
 * calling thread takes part. Returns when every range is done.
 *
 * - With more than one thread, the ranges are [k * grain, (k + 1) * grain) (the last one
 *   shorter), taken in any order by whichever thread is free; with one thread, or n <=
 *   grain, body sees [0, n) in one call. Code whose result must not depend on the thread
 *   count reduces over fixed blocks (deterministicReduce() in reduction.h), never over
 *   ranges.
 * - `slot` is in [0, num_threads) and distinct among ranges that run at the same time:
 *   the index of per-thread state (paper Sec. IV-B), such as a padded search slot.
 * - A call from inside a body, or while another thread's call holds the pool, runs on the
 *   calling thread alone (slot 0).
 * - An exception thrown by body stops the ranges not yet started and is rethrown here.
 */
template <typename Body>
void
parallelFor(std::size_t n, unsigned num_threads, std::size_t grain, Body&& body)
{
  using B = std::remove_reference_t<Body>;
  static_assert(std::is_invocable_v<B&, std::size_t, std::size_t, unsigned> ||
                    std::is_invocable_v<B&, std::size_t, std::size_t>,
                "body(begin, end[, slot])");
  if (n == 0)
    return;
  if (grain == 0)
    grain = 1;
  const auto call = [](void* b, std::size_t begin, std::size_t end, unsigned slot) {
    B& f = *static_cast<B*>(b);
    if constexpr (std::is_invocable_v<B&, std::size_t, std::size_t, unsigned>)
      f(begin, end, slot);
    else
      f(begin, end);
  };
  void* erased = const_cast<void*>(static_cast<const void*>(std::addressof(body)));
  const unsigned threads = resolveNumberOfThreads(num_threads);
  if (threads <= 1 || n <= grain)
    call(erased, 0, n, 0);
  else
    detail::parallelRanges(n, grain, threads, call, erased);
}

/** Grain that cuts n items into about 4 ranges per thread, at least \a min_grain items
 *  each: for loops whose items cost about the same. */
inline std::size_t
evenGrain(std::size_t n, unsigned threads, std::size_t min_grain = 1024)
{
  const std::size_t parts = 4 * static_cast<std::size_t>(threads > 0 ? threads : 1);
  const std::size_t g = (n + parts - 1) / parts;
  return g > min_grain ? g : min_grain;
}

} // namespace pcl_parallel
