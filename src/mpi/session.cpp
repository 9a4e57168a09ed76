/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * mpi::Session with MPI (no_session.cpp without).
 */
#include <pcl_parallel/mpi/distributed_lum.h>
#include <pcl_parallel/mpi/session.h>

#include <cstdlib>
#include <string>

namespace pcl_parallel {
namespace mpi {

Session::Session(int& argc, char**& argv)
{
  bool launched = false;
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "PMIX_RANK"})
    launched = launched || std::getenv(name) != nullptr;
  if (!launched)
    return;
  // Threads inside a rank, MPI calls from the main thread only.
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  initialised_ = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
}

Session::~Session()
{
  if (initialised_)
    MPI_Finalize();
}

void
Session::agree(const std::function<void()>& step) const
{
  if (size_ == 1) {
    step();
    return;
  }
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
    throwIfAnyFailed(MPI_COMM_WORLD, message);
  }
  catch (const CollectiveError&) {
    failed_together_ = true;
    if (failure) // this rank's own error keeps its type (and so its exit status)
      std::rethrow_exception(failure);
    throw;
  }
}

bool
Session::collective(const std::exception& error) const
{
  return failed_together_ || dynamic_cast<const CollectiveError*>(&error) != nullptr;
}

int
Session::broadcast(int value) const
{
  if (size_ > 1)
    MPI_Bcast(&value, 1, MPI_INT, 0, MPI_COMM_WORLD);
  return value;
}

std::string
Session::broadcast(const std::string& text) const
{
  if (size_ == 1)
    return text;
  std::string value = text;
  value.resize(static_cast<std::size_t>(broadcast(static_cast<int>(text.size()))));
  MPI_Bcast(value.data(), static_cast<int>(value.size()), MPI_CHAR, 0, MPI_COMM_WORLD);
  return value;
}

} // namespace mpi
} // namespace pcl_parallel
