/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "backends.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <memory>
#include <mutex>
#include <pthread.h>
#include <system_error>
#include <thread>
#include <vector>

// The pool behind parallelFor() (docs/design.md, "Threads"). A call publishes a job of
// fixed ranges; the caller and whichever workers are awake take ranges from one counter,
// and the caller returns as soon as the last range is done. Nobody waits for a worker that
// has not started: on a busy machine a worker that gets no core costs nothing, where a
// barrier (OpenMP's end of a parallel region) would hold every thread until it ran.

namespace pcl_parallel::detail {

namespace {

/** How long a thread spins before it sleeps: enough to catch the next job of an ICP
 *  iteration loop, short enough to cost a busy machine nothing noticeable. */
constexpr std::chrono::microseconds kSpin{50};

thread_local bool t_in_body = false; // a nested parallelFor() runs inline

inline void
relax()
{
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#endif
}

/** Spins until \a ready() or kSpin has passed; true when ready. */
template <typename Ready>
bool
spinUntil(Ready&& ready)
{
  const auto until = std::chrono::steady_clock::now() + kSpin;
  for (unsigned i = 1;; ++i) {
    if (ready())
      return true;
    relax();
    if (i % 64 == 0 && std::chrono::steady_clock::now() > until)
      return ready();
  }
}

struct Job {
  RangeFunction f = nullptr;
  void* body = nullptr;
  std::size_t n = 0, grain = 1, ranges = 0;
  unsigned threads = 1;
  std::atomic<std::size_t> next{0};
  std::atomic<std::size_t> finished{0};
  std::atomic<unsigned> slots{1}; // slot 0 is the caller's
  std::atomic<bool> failed{false};
  std::exception_ptr error; // written by the thread that set failed, before it finishes
  std::mutex mutex;
  std::condition_variable done;
  bool caller_sleeps = false;

  bool
  complete() const
  {
    return finished.load(std::memory_order_acquire) == ranges;
  }

  /** Takes ranges until none is left. A range is only run while the job is incomplete,
   *  so f and body (the caller's) are never touched after the caller returned. */
  void
  work(unsigned slot)
  {
    t_in_body = true;
    for (;;) {
      const std::size_t r = next.fetch_add(1, std::memory_order_relaxed);
      if (r >= ranges)
        break;
      if (!failed.load(std::memory_order_relaxed)) {
        const std::size_t begin = r * grain;
        try {
          f(body, begin, std::min(n, begin + grain), slot);
        }
        catch (...) {
          if (!failed.exchange(true))
            error = std::current_exception();
        }
      }
      if (finished.fetch_add(1, std::memory_order_acq_rel) + 1 == ranges) {
        std::lock_guard<std::mutex> lock(mutex);
        if (caller_sleeps)
          done.notify_one();
      }
    }
    t_in_body = false;
  }

  void
  waitComplete()
  {
    if (spinUntil([this] { return complete(); }))
      return;
    std::unique_lock<std::mutex> lock(mutex);
    caller_sleeps = true;
    done.wait(lock, [this] { return complete(); });
  }
};

class ThreadPool {
public:
  /** Runs \a job on the caller and the workers; false (nothing run) when another thread's
   *  job holds the pool. */
  bool
  run(const std::shared_ptr<Job>& job)
  {
    if (taken_.exchange(true, std::memory_order_acquire))
      return false;
    unsigned wake = 0;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      try {
        while (workers_.size() + 1 < job->threads)
          workers_.emplace_back([this] { serve(); });
      }
      catch (const std::system_error&) { // no more threads to be had: run with those there
      }
      job_ = job;
      published_.store(++epoch_, std::memory_order_release);
      wake = std::min(sleeping_, job->threads - 1);
    }
    for (unsigned i = 0; i < wake; ++i)
      wake_.notify_one();
    job->work(0);
    job->waitComplete();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      job_.reset(); // a late worker keeps its own reference to the finished job
    }
    taken_.store(false, std::memory_order_release);
    return true;
  }

private:
  /** A worker: joins each new job while it has free slots, spins briefly, then sleeps. */
  void
  serve()
  {
    std::uint64_t seen = 0;
    for (;;) {
      spinUntil([&] { return published_.load(std::memory_order_acquire) != seen; });
      std::shared_ptr<Job> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        if (epoch_ == seen) {
          ++sleeping_;
          wake_.wait(lock, [&] { return epoch_ != seen; });
          --sleeping_;
        }
        seen = epoch_;
        job = job_;
      }
      if (!job)
        continue;
      const unsigned slot = job->slots.fetch_add(1, std::memory_order_relaxed);
      if (slot < job->threads)
        job->work(slot);
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_;
  std::shared_ptr<Job> job_;                // guarded by mutex_
  std::uint64_t epoch_ = 0;                 // guarded by mutex_
  unsigned sleeping_ = 0;                   // guarded by mutex_
  std::vector<std::thread> workers_;        // guarded by mutex_
  std::atomic<std::uint64_t> published_{0}; // epoch_, read by spinning workers
  std::atomic<bool> taken_{false};
};

// One pool per process, never destroyed: workers sleep until the process ends, so no
// static destructor joins a thread. A forked child starts a pool of its own (its parent's
// workers do not exist there).
ThreadPool* g_pool = nullptr;
std::once_flag g_pool_once;

ThreadPool&
pool()
{
  std::call_once(g_pool_once, [] {
    g_pool = new ThreadPool;
    pthread_atfork(nullptr, nullptr, [] { g_pool = new ThreadPool; });
  });
  return *g_pool;
}

} // namespace

void
runOnPool(std::size_t n, std::size_t grain, unsigned threads, RangeFunction f, void* body)
{
  if (t_in_body) {
    f(body, 0, n, 0);
    return;
  }
  auto job = std::make_shared<Job>();
  job->f = f;
  job->body = body;
  job->n = n;
  job->grain = grain;
  job->ranges = (n + grain - 1) / grain;
  job->threads = threads;
  if (!pool().run(job)) {
    f(body, 0, n, 0); // another thread's job holds the pool: this one runs alone
    return;
  }
  if (job->error)
    std::rethrow_exception(job->error);
}

} // namespace pcl_parallel::detail
