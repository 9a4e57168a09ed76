/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "../extern_templates.h"

#include <pcl_parallel/mpi/impl/distributed_lum.hpp>
#include <pcl_parallel/point_types.h>

#include <pcl/impl/instantiate.hpp>
#include <pcl/point_types.h>

namespace pcl_parallel {
namespace mpi {

std::pair<std::size_t, std::size_t>
linkRange(std::size_t num_links, int rank, int size)
{
  const std::size_t r = static_cast<std::size_t>(rank), s = static_cast<std::size_t>(size);
  const std::size_t base = num_links / s, extra = num_links % s;
  const std::size_t begin = r * base + std::min(r, extra);
  return {begin, begin + base + (r < extra ? 1 : 0)};
}

void
requireSameOnAllRanks(MPI_Comm comm, std::uint64_t hash, const std::string& what)
{
  std::uint64_t lo = 0, hi = 0;
  MPI_Allreduce(&hash, &lo, 1, MPI_UINT64_T, MPI_MIN, comm);
  MPI_Allreduce(&hash, &hi, 1, MPI_UINT64_T, MPI_MAX, comm);
  if (lo != hi)
    throw CollectiveError(what + " differ between ranks");
}

void
throwIfAnyFailed(MPI_Comm comm, const std::string& error)
{
  int failed = error.empty() ? 0 : 1, any = 0;
  MPI_Allreduce(&failed, &any, 1, MPI_INT, MPI_MAX, comm);
  if (!any)
    return;
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  // Rank 0 collects every rank's message and composes the one all ranks throw.
  int length = static_cast<int>(error.size());
  std::vector<int> lengths(size), displs(size);
  MPI_Gather(&length, 1, MPI_INT, lengths.data(), 1, MPI_INT, 0, comm);
  std::string texts;
  if (rank == 0) {
    for (int r = 1; r < size; ++r)
      displs[r] = displs[r - 1] + lengths[r - 1];
    texts.resize(static_cast<std::size_t>(displs[size - 1] + lengths[size - 1]));
  }
  MPI_Gatherv(error.data(),
              length,
              MPI_CHAR,
              texts.data(),
              lengths.data(),
              displs.data(),
              MPI_CHAR,
              0,
              comm);
  std::string message;
  if (rank == 0)
    for (int r = 0; r < size; ++r)
      if (lengths[r] > 0)
        message += (message.empty() ? "" : "; ") + std::string("rank ") + std::to_string(r) +
                   " of " + std::to_string(size) + ": " +
                   texts.substr(static_cast<std::size_t>(displs[r]),
                                static_cast<std::size_t>(lengths[r]));
  int message_length = static_cast<int>(message.size());
  MPI_Bcast(&message_length, 1, MPI_INT, 0, comm);
  message.resize(static_cast<std::size_t>(message_length));
  MPI_Bcast(message.data(), message_length, MPI_CHAR, 0, comm);
  throw CollectiveError(message);
}

} // namespace mpi
} // namespace pcl_parallel

PCL_INSTANTIATE(DistributedLUM, PCL_PARALLEL_XYZ_POINT_TYPES)
