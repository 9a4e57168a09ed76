/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/mpi/distributed_lum.h>

namespace pcl_parallel {
namespace test {

inline int
worldRank()
{
  int r = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &r);
  return r;
}

inline int
worldSize()
{
  int s = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &s);
  return s;
}

} // namespace test
} // namespace pcl_parallel
