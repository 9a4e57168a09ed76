/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "backends.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <exception>

namespace pcl_parallel::detail {

void
runOnOpenMP(std::size_t n, std::size_t grain, unsigned threads, RangeFunction f, void* body)
{
  if (omp_in_parallel()) { // nested: on this thread, as the pool does
    f(body, 0, n, 0);
    return;
  }
  const std::int64_t ranges = static_cast<std::int64_t>((n + grain - 1) / grain);
  std::atomic<bool> failed{false};
  std::exception_ptr error;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
  for (std::int64_t r = 0; r < ranges; ++r) {
    if (failed.load(std::memory_order_relaxed))
      continue;
    const std::size_t begin = static_cast<std::size_t>(r) * grain;
    try {
      f(body, begin, std::min(n, begin + grain), static_cast<unsigned>(omp_get_thread_num()));
    }
    catch (...) {
      if (!failed.exchange(true))
        error = std::current_exception();
    }
  }
  if (error)
    std::rethrow_exception(error);
}

} // namespace pcl_parallel::detail
