/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

// The backends of parallelFor(), siblings behind detail::parallelRanges() (threads.cpp).

#include <pcl_parallel/parallel.h>

namespace pcl_parallel::detail {

/** The library's pool (thread_pool.cpp). */
void
runOnPool(std::size_t n, std::size_t grain, unsigned threads, RangeFunction f, void* body);

/** OpenMP's runtime (openmp.cpp). */
void
runOnOpenMP(std::size_t n, std::size_t grain, unsigned threads, RangeFunction f, void* body);

} // namespace pcl_parallel::detail
