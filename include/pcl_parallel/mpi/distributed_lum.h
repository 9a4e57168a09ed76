/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/registration/lum.h>

#include <cstdint>
#include <cstring>
#include <functional>
// MPI's C API only: Open MPI's and MPICH's deprecated C++ bindings would need their C++
// library (libmpi_cxx) too.
#ifndef OMPI_SKIP_MPICXX
#define OMPI_SKIP_MPICXX 1
#endif
#ifndef MPICH_SKIP_MPICXX
#define MPICH_SKIP_MPICXX 1
#endif
#include <mpi.h>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace pcl_parallel {
namespace mpi {

/** Links [first, second) of `num_links` owned by `rank` of `size`: contiguous blocks, the
 *  first num_links % size ranks one link more. */
std::pair<std::size_t, std::size_t>
linkRange(std::size_t num_links, int rank, int size);

/** FNV-1a over values' bytes: compares options and graphs across ranks. */
struct Fnv1a {
  /** The hash so far (FNV-1a's offset basis at the start). */
  std::uint64_t value = 14695981039346656037ull;
  /** Hashes the bytes of \a v into value. */
  template <typename T>
  void
  add(const T& v)
  {
    unsigned char bytes[sizeof(v)];
    std::memcpy(bytes, &v, sizeof(v));
    for (unsigned char b : bytes)
      value = (value ^ b) * 1099511628211ull;
  }
};

/** An error every rank of a communicator throws together (throwIfAnyFailed), with the
 *  same message: a program may end all ranks in step on it. */
struct CollectiveError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/** Collective: unless every rank passes the same `hash` (of its options and inputs), every
 *  rank throws CollectiveError(what + " differ between ranks"). */
void
requireSameOnAllRanks(MPI_Comm comm, std::uint64_t hash, const std::string& what);

/** Collective: if any rank's `error` is non-empty, every rank throws CollectiveError with
 *  one message composed on rank 0 ("rank r of N: error", for each failed rank). */
void
throwIfAnyFailed(MPI_Comm comm, const std::string& error);

/**
 * \brief pLUM (ParallelLUM in pLUM mode) over the ranks of an MPI communicator, with poses
 * bit-identical to one ParallelLUM on the same input for any rank and thread count.
 *
 * The links, in ParallelLUM's order (sorted by (source, target)), are split over the
 * ranks in contiguous blocks (linkRange). A rank loads and keeps only the clouds of the
 * vertices of its links, and builds only their trees. Per iteration each rank computes
 * its links' blocks (paper steps 1-2, with ParallelLUM's own code and OpenMP threads);
 * the blocks go to rank 0 in link order (a gather, not a floating-point MPI_Reduce, so
 * the system is assembled in the same order as in one process); rank 0 solves and updates
 * the poses (steps 3-5, ParallelLUM's code) and broadcasts them. All calls are collective.
 *
 * Errors (a cloud that cannot be loaded, an invalid graph, options that differ between
 * ranks) are agreed on by all ranks: each throws the same std::runtime_error, composed
 * on rank 0 and naming the failing ranks, instead of one rank hanging in a collective.
 */
template <typename PointT>
class DistributedLUM {
public:
  /** The single-process pLUM this drives. */
  using Lum = ParallelLUM<PointT>;
  /** Shared pointer to a scan cloud. */
  using PointCloudPtr = typename Lum::PointCloudPtr;
  /** Returns the scan of a vertex (e.g. read from its file); throws on failure. */
  using CloudLoader = std::function<PointCloudPtr(std::size_t vertex)>;

  /** A driver over the ranks of \a comm (all must construct it with the same graph). */
  explicit DistributedLUM(MPI_Comm comm = MPI_COMM_WORLD);

  /** The options of the relaxation (pLUM mode is required: setCorrespondenceDistance or
   *  setCorrespondenceDistanceSchedule). Set them the same on every rank, except the
   *  number of threads; compute() checks. The iteration callback runs on rank 0. */
  Lum&
  lum()
  {
    return lum_;
  }

  /** Collective. The graph: start poses (rank 0's are used) and links (i, j), the same on
   *  every rank; then this rank's clouds through `loader`, called for the vertices of
   *  the links it owns only, in increasing order. */
  void
  setGraph(const std::vector<Eigen::Matrix4d>& poses,
           const std::vector<std::pair<std::size_t, std::size_t>>& links,
           const CloudLoader& loader);

  /** Collective: runs lum().getMaxIterations() iterations at most, as ParallelLUM. */
  void
  compute();

  /** The rank that measures a link (source, target) in computeOn. */
  using LinkOwner = std::function<int(std::size_t source, std::size_t target)>;

  /** Collective: compute() on a ParallelLUM that holds the same graph on every rank and
   *  the clouds of the links this rank measures: those `owner` gives it (e.g. the rank
   *  that keeps the source scan, as mpi::RankExchange does), or without one the
   *  split of setGraph. `remote_reasons` keeps the texts of links dropped on other ranks
   *  (the ParallelLUM points to them) and must outlive it. */
  static void
  computeOn(Lum& lum,
            MPI_Comm comm,
            std::vector<std::string>& remote_reasons,
            const LinkOwner& owner = {});

  /** The pose of any vertex, the same on every rank after compute(). */
  Eigen::Matrix4d
  getPoseMatrix(std::size_t vertex) const
  {
    return lum_.getPoseMatrix(vertex);
  }
  /** Number of vertices (scans) of the graph. */
  std::size_t
  getNumVertices() const
  {
    return lum_.getNumVertices();
  }
  /** This rank's links, as indices into ParallelLUM's link order. */
  std::pair<std::size_t, std::size_t>
  getOwnedLinks() const
  {
    return owned_;
  }
  /** The vertices whose clouds this rank loaded. */
  const std::vector<std::size_t>&
  getLoadedVertices() const
  {
    return loaded_;
  }
  /** Payload bytes sent per iteration by all ranks together: the blocks of the links of
   *  ranks 1..N-1 to rank 0 and the poses from rank 0 to the N-1 others. */
  std::uint64_t
  getBytesPerIteration() const
  {
    return bytesPerIteration(num_links_, lum_.getNumVertices(), size_);
  }
  /** ... for a graph of num_links links and num_vertices vertices over `size` ranks. */
  static std::uint64_t
  bytesPerIteration(std::size_t num_links, std::size_t num_vertices, int size);
  /** ... when `remote_links` links are measured off rank 0 (e.g. computeOn's owner). */
  static std::uint64_t
  iterationBytes(std::size_t remote_links, std::size_t num_vertices, int size);
  /** This process's rank in the communicator. */
  int
  getRank() const
  {
    return rank_;
  }
  /** Number of ranks in the communicator. */
  int
  getSize() const
  {
    return size_;
  }

private:
  /** A link's block as sent to rank 0 (plain bytes; the reason a link was dropped travels
   *  as text because ParallelLUM keeps it as a pointer). */
  struct WireLink {
    double info[36];
    double grad[6];
    std::uint64_t pairs;
    std::uint32_t source, target;
    std::int32_t valid;
    char reason[84];
  };

  /** Hash of the graph and of the options that change the result. */
  static std::uint64_t
  configHash(const Lum& lum);
  /** Starts computeOn() on every rank: each link's owning rank in `owners` (link order),
   *  this rank's links in `run`; throws on every rank where one fails or the ranks'
   *  graphs or options differ. */
  static void
  beginOn(Lum& lum,
          MPI_Comm comm,
          typename Lum::Run& run,
          std::vector<int>& owners,
          const LinkOwner& owner,
          const std::string& where);
  /** This rank's link blocks of the iteration as sent to rank 0, in link order. */
  static void
  packLinks(const typename Lum::Run& run, std::vector<WireLink>& mine);
  /** Rank 0: the gathered blocks of the other ranks' links back at their links' places
   *  (`displs`: each rank's first byte in `all`). */
  static void
  unpackLinks(typename Lum::Run& run,
              const std::vector<WireLink>& all,
              const std::vector<int>& owners,
              const std::vector<int>& displs,
              std::vector<std::string>& remote_reasons);
  /** Rank 0's poses and `control` values to every rank. */
  static void
  broadcastPoses(
      Lum& lum, MPI_Comm comm, std::vector<double>& buffer, double* control, int num_control);

  MPI_Comm comm_;
  int rank_ = 0;
  int size_ = 1;
  Lum lum_;
  std::size_t num_links_ = 0;
  std::pair<std::size_t, std::size_t> owned_{0, 0};
  std::vector<std::size_t> loaded_;
  std::vector<std::string> remote_reasons_;
};

} // namespace mpi
} // namespace pcl_parallel

#ifdef PCL_NO_PRECOMPILE
#include <pcl_parallel/mpi/impl/distributed_lum.hpp>
#endif
