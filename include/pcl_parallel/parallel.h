/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <cstddef>

namespace pcl_parallel {

/** Size the per-thread search state is padded to (paper Sec. IV-B): one x86-64 cache
 *  line. A constant, not std::hardware_destructive_interference_size, so the ABI does not
 *  depend on compiler flags. */
constexpr std::size_t kCacheLineSize = 64;

/** Largest thread count accepted; larger requests (e.g. a negative int cast to
 *  unsigned) are clamped with a warning instead of allocating state for billions of
 *  threads. */
constexpr unsigned kMaxThreads = 1024;

/** Resolves a user's thread request: 0 means "all cores" (omp_get_max_threads()),
 *  anything above kMaxThreads is clamped (with a PCL_WARN). Always returns >= 1. */
unsigned
resolveNumberOfThreads(unsigned requested);

/** Number of hardware threads OpenMP would use by default. */
unsigned
hardwareThreads();

} // namespace pcl_parallel
