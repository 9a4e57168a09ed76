/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/parallel.h>

#include <pcl/console/print.h>

#include <omp.h>

#include <algorithm>

namespace pcl_parallel {

unsigned
hardwareThreads()
{
  return static_cast<unsigned>(std::max(1, omp_get_max_threads()));
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

} // namespace pcl_parallel
