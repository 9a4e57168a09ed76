/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "ranks.h"

#ifdef PCL_PARALLEL_WITH_MPI
#include <pcl_parallel/mpi/distributed_lum.h>
#endif

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <stdexcept>
#include <string>

namespace pcl_pslam {

Ranks::Ranks([[maybe_unused]] int& argc, [[maybe_unused]] char**& argv)
{
#ifdef PCL_PARALLEL_WITH_MPI
  bool launched = false;
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"})
    launched = launched || std::getenv(name) != nullptr;
  if (!launched)
    return;
  // OpenMP threads inside a rank, MPI calls from the main thread only.
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  initialised_ = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
#endif
}

Ranks::~Ranks()
{
#ifdef PCL_PARALLEL_WITH_MPI
  if (initialised_)
    MPI_Finalize();
#endif
}

void
Ranks::agree(const std::function<void()>& step) const
{
  if (size_ == 1) {
    step();
    return;
  }
#ifdef PCL_PARALLEL_WITH_MPI
  std::exception_ptr failure;
  std::string message;
  try {
    step();
  }
  catch (const std::exception& e) {
    failure = std::current_exception();
    message = e.what();
    if (message.empty())
      message = "failed";
  }
  try {
    pcl_parallel::mpi::throwIfAnyFailed(MPI_COMM_WORLD, message);
  }
  catch (const pcl_parallel::mpi::CollectiveError&) {
    failed_together_ = true;
    if (failure) // this rank's own error keeps its type (and so its exit status)
      std::rethrow_exception(failure);
    throw;
  }
#endif
}

int
Ranks::fail(int status, const std::string& message, const std::exception& error) const
{
  if (size_ > 1) { // the run is over: the launcher's SIGTERM to the others adds nothing
    std::signal(SIGINT, SIG_IGN);
    std::signal(SIGTERM, SIG_IGN);
  }
  if (rank_ == 0)
    std::fprintf(stderr, "pcl_pslam: %s\n", message.c_str());
#ifdef PCL_PARALLEL_WITH_MPI
  const bool together =
      failed_together_ ||
      dynamic_cast<const pcl_parallel::mpi::CollectiveError*>(&error) != nullptr;
  if (size_ > 1 && together) {
    std::fflush(stderr);
    MPI_Bcast(&status, 1, MPI_INT, 0, MPI_COMM_WORLD); // after rank 0 has spoken
  }
#else
  (void)error;
#endif
  return status;
}

} // namespace pcl_pslam
