/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <exception>
#include <functional>
#include <string>

namespace pcl_parallel {
namespace mpi {

/**
 * \brief A program's place among MPI ranks. Under an MPI launcher (mpirun, mpiexec, srun:
 * they set OMPI_COMM_WORLD_SIZE, PMI_SIZE or PMIX_RANK) MPI is initialised for the
 * session's lifetime; a process started alone is rank 0 of 1 and never touches MPI, so it
 * needs no launcher. Without MPI in the build (src/mpi/no_session.cpp) every process is
 * rank 0 of 1.
 */
class Session {
public:
  /** Initialises MPI when started by a launcher (mpirun), else nothing; \a argc and \a argv as
   *  main's. */
  Session(int& argc, char**& argv);
  ~Session();
  Session(const Session&) = delete;
  Session&
  operator=(const Session&) = delete;

  /** This process's rank (0 without a launcher). */
  int
  rank() const
  {
    return rank_;
  }
  /** Number of ranks (1 without a launcher). */
  int
  size() const
  {
    return size_;
  }

  /** Runs `step` on this rank; then, with several ranks, all agree (collective): if it
   *  threw on any rank, it throws on every rank, the original exception where it was
   *  thrown and elsewhere a CollectiveError composed on rank 0 naming the ranks
   *  (throwIfAnyFailed). Alone: just runs `step`. */
  void
  agree(const std::function<void()>& step) const;

  /** Whether `error` ended the run on all ranks together: thrown by agree(), or a
   *  CollectiveError of the library. */
  bool
  collective(const std::exception& error) const;

  /** Rank 0's `value`, on every rank (collective). */
  int
  broadcast(int value) const;
  /** Rank 0's `text`, on every rank (collective). */
  std::string
  broadcast(const std::string& text) const;

private:
  int rank_ = 0;
  int size_ = 1;
  bool initialised_ = false;
  mutable bool failed_together_ = false; ///< agree() threw
};

} // namespace mpi
} // namespace pcl_parallel
