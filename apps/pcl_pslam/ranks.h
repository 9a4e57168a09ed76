/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <exception>
#include <functional>
#include <string>

namespace pcl_pslam {

/**
 * \brief The app's MPI session: under an MPI launcher (mpirun, mpiexec, srun: they set
 * OMPI_COMM_WORLD_SIZE, PMI_SIZE or PMIX_RANK) MPI is initialised for the process's
 * lifetime; a process started alone is rank 0 of 1 and never touches MPI, so it needs
 * no launcher (and the app builds without MPI).
 */
class Ranks {
public:
  Ranks(int& argc, char**& argv);
  ~Ranks();
  Ranks(const Ranks&) = delete;
  Ranks&
  operator=(const Ranks&) = delete;

  int
  rank() const
  {
    return rank_;
  }
  int
  size() const
  {
    return size_;
  }

  /** Runs `step` on this rank; then, with several ranks, all agree (collective): if it
   *  threw on any rank, it throws on every rank, the original exception where it was
   *  thrown and elsewhere a std::runtime_error composed on rank 0 naming the ranks
   *  (mpi::throwIfAnyFailed). Alone: just runs `step`. */
  void
  agree(const std::function<void()>& step) const;

  /** Ends a failed run on every rank in step, if the failure was collective (thrown by
   *  agree, or a CollectiveError of the library): rank 0 prints `message` (to stderr, as
   *  "pcl_pslam: message") and only then do all return its `status`, so the launcher,
   *  which ends the job at the first non-zero exit, cannot cut rank 0's message short.
   *  A failure of this rank alone: it returns `status` at once (the launcher ends the
   *  others). Only rank 0 ever prints. */
  int
  fail(int status, const std::string& message, const std::exception& error) const;

private:
  int rank_ = 0;
  int size_ = 1;
  bool initialised_ = false;
  mutable bool failed_together_ = false; ///< agree() threw
};

} // namespace pcl_pslam
