/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * slam::mapSequence's kRanks backend in a build without MPI (ranks_backend.cpp with).
 */
#include <pcl_parallel/slam/mapping.h>

#include <stdexcept>

namespace pcl_parallel {
namespace slam {
namespace detail {

std::unique_ptr<Pipeline>
mapOverRanks(const Parameters&,
             const MappingOptions&,
             std::size_t,
             const ScanSource&,
             MappingReport&,
             const SegmentProgress&)
{
  throw std::runtime_error("mapping over MPI ranks: pcl_parallel was built without MPI");
}

} // namespace detail
} // namespace slam
} // namespace pcl_parallel
