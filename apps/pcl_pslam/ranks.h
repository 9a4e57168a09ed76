/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <functional>

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

private:
  int rank_ = 0;
  int size_ = 1;
  bool initialised_ = false;
};

} // namespace pcl_pslam
