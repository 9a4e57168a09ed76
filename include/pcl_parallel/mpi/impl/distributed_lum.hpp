/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/mpi/distributed_lum.h>
#include <pcl_parallel/registration/impl/lum.hpp>

#include <algorithm>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace pcl_parallel {
namespace mpi {

template <typename PointT>
DistributedLUM<PointT>::DistributedLUM(MPI_Comm comm)
    : comm_(comm)
{
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
}

template <typename PointT>
void
DistributedLUM<PointT>::setGraph(const std::vector<Eigen::Matrix4d>& poses,
                                 const std::vector<std::pair<std::size_t, std::size_t>>& links,
                                 const CloudLoader& loader)
{
  std::string error;
  try {
    lum_.setLoopGraph(typename Lum::SLAMGraphPtr(new typename Lum::SLAMGraph));
    loaded_.clear();
    for (std::size_t v = 0; v < poses.size(); ++v)
      lum_.addPointCloud(PointCloudPtr(), Eigen::Matrix4f::Identity());
    for (std::size_t v = 0; v < poses.size(); ++v)
      lum_.setPoseMatrix(v, poses[v]);
    for (const auto& [i, j] : links)
      lum_.addLink(i, j);
    // Ownership follows ParallelLUM's link order, so the gathered blocks are in it.
    const auto refs = lum_.collectLinks();
    num_links_ = refs.size();
    owned_ = linkRange(num_links_, rank_, size_);
    std::vector<char> needed(poses.size(), 0);
    for (std::size_t li = owned_.first; li < owned_.second; ++li)
      needed[refs[li].source] = needed[refs[li].target] = 1;
    for (std::size_t v = 0; v < poses.size(); ++v) {
      if (!needed[v])
        continue;
      PointCloudPtr cloud;
      try {
        cloud = loader(v);
      }
      catch (const std::exception& e) {
        throw std::runtime_error("scan " + std::to_string(v) + ": " + e.what());
      }
      if (!cloud || cloud->empty())
        throw std::runtime_error("scan " + std::to_string(v) + ": no points");
      lum_.setPointCloud(v, cloud);
      loaded_.push_back(v);
    }
  }
  catch (const std::exception& e) {
    error = e.what();
  }
  throwIfAnyFailed(comm_, error);
}

template <typename PointT>
std::uint64_t
DistributedLUM<PointT>::configHash(const Lum& lum)
{
  Fnv1a h;
  auto add = [&h](const auto& value) { h.add(value); };
  add(static_cast<std::uint64_t>(lum.getNumVertices()));
  for (const auto& l : lum.collectLinks()) {
    add(static_cast<std::uint64_t>(l.source));
    add(static_cast<std::uint64_t>(l.target));
  }
  add(lum.max_iterations_);
  add(lum.convergence_threshold_);
  add(lum.correspondence_distance_);
  add(lum.final_correspondence_distance_);
  add(lum.correspondence_distance_factor_);
  add(static_cast<int>(lum.point_to_plane_));
  add(lum.point_to_point_weight_);
  add(static_cast<std::uint64_t>(lum.normal_neighbours_));
  add(lum.link_iterations_);
  add(static_cast<std::uint64_t>(lum.min_correspondences_));
  add(static_cast<int>(lum.symmetric_));
  add(static_cast<std::uint64_t>(lum.query_step_));
  for (const auto& c : lum.constraints_) {
    add(static_cast<std::uint64_t>(c.source));
    add(static_cast<std::uint64_t>(c.target));
  }
  return h.value;
}

template <typename PointT>
void
DistributedLUM<PointT>::broadcastPoses(
    Lum& lum, MPI_Comm comm, std::vector<double>& buffer, double* control, int num_control)
{
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  const std::size_t n = lum.poses_.size();
  buffer.resize(16 * n + static_cast<std::size_t>(num_control));
  if (rank == 0) {
    for (std::size_t v = 0; v < n; ++v)
      Eigen::Matrix4d::Map(&buffer[16 * v]) = lum.poses_[v];
    std::copy(control, control + num_control, buffer.begin() + 16 * n);
  }
  MPI_Bcast(buffer.data(), static_cast<int>(buffer.size()), MPI_DOUBLE, 0, comm);
  if (rank != 0) {
    for (std::size_t v = 0; v < n; ++v)
      lum.poses_[v] = Eigen::Matrix4d::Map(&buffer[16 * v]);
    std::copy(buffer.begin() + 16 * n, buffer.end(), control);
  }
}

template <typename PointT>
std::uint64_t
DistributedLUM<PointT>::bytesPerIteration(std::size_t num_links,
                                          std::size_t num_vertices,
                                          int size)
{
  return iterationBytes(num_links - linkRange(num_links, 0, size).second, num_vertices, size);
}

template <typename PointT>
std::uint64_t
DistributedLUM<PointT>::iterationBytes(std::size_t remote_links,
                                       std::size_t num_vertices,
                                       int size)
{
  // The blocks to rank 0; the poses and 4 control values from it.
  return remote_links * sizeof(WireLink) +
         static_cast<std::uint64_t>(size - 1) * (16 * num_vertices + 4) * sizeof(double);
}

template <typename PointT>
void
DistributedLUM<PointT>::compute()
{
  computeOn(lum_, comm_, remote_reasons_);
}

template <typename PointT>
void
DistributedLUM<PointT>::beginOn(Lum& lum,
                                MPI_Comm comm,
                                typename Lum::Run& run,
                                std::vector<int>& owners,
                                const LinkOwner& owner,
                                const std::string& where)
{
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  std::string error;
  try {
    if (!(lum.getCorrespondenceDistance() > 0.0))
      throw std::invalid_argument(where + "needs pLUM mode (setCorrespondenceDistance)");
    lum.beginCompute(run, [&](const std::vector<typename Lum::LinkRef>& links) {
      owners.resize(links.size());
      if (!owner)
        for (int r = 0; r < size; ++r) {
          const auto range = linkRange(links.size(), r, size);
          std::fill(owners.begin() + range.first, owners.begin() + range.second, r);
        }
      else
        for (std::size_t li = 0; li < links.size(); ++li) {
          owners[li] = owner(links[li].source, links[li].target);
          if (owners[li] < 0 || owners[li] >= size)
            throw std::out_of_range(where + "link " + std::to_string(links[li].source) +
                                    " -> " + std::to_string(links[li].target) +
                                    " is owned by no rank");
        }
      std::vector<std::size_t> mine;
      for (std::size_t li = 0; li < links.size(); ++li)
        if (owners[li] == rank)
          mine.push_back(li);
      return mine;
    });
  }
  catch (const std::exception& e) {
    error = e.what();
  }
  throwIfAnyFailed(comm, error);
  // Every rank must run the same relaxation (only the thread count may differ).
  requireSameOnAllRanks(comm, configHash(lum), where + "the graph or the pLUM options");
}

template <typename PointT>
void
DistributedLUM<PointT>::packLinks(const typename Lum::Run& run, std::vector<WireLink>& mine)
{
  for (std::size_t k = 0; k < run.mine.size(); ++k) {
    const std::size_t li = run.mine[k];
    const lum::LinkBlock& b = run.blocks[li];
    WireLink& w = mine[k];
    std::memset(&w, 0, sizeof(w));
    Eigen::Map<lum::Matrix6d>(w.info) = b.info;
    Eigen::Map<lum::Vector6d>(w.grad) = b.grad;
    w.pairs = run.pair_counts[li];
    w.source = b.source;
    w.target = b.target;
    w.valid = b.valid;
    if (run.reasons[li])
      std::strncpy(w.reason, run.reasons[li], sizeof(w.reason) - 1);
  }
}

template <typename PointT>
void
DistributedLUM<PointT>::unpackLinks(typename Lum::Run& run,
                                    const std::vector<WireLink>& all,
                                    const std::vector<int>& owners,
                                    const std::vector<int>& displs,
                                    std::vector<std::string>& remote_reasons)
{
  std::vector<std::size_t> next(displs.begin(), displs.end()); // per rank, in bytes
  for (std::size_t li = 0; li < run.links.size(); ++li) {
    const int r = owners[li];
    const WireLink& w = all[next[r] / sizeof(WireLink)];
    next[r] += sizeof(WireLink);
    if (r == 0)
      continue; // measured here
    lum::LinkBlock& b = run.blocks[li];
    b.info = Eigen::Map<const lum::Matrix6d>(w.info);
    b.grad = Eigen::Map<const lum::Vector6d>(w.grad);
    b.source = w.source;
    b.target = w.target;
    b.valid = w.valid != 0;
    run.pair_counts[li] = w.pairs;
    remote_reasons[li] = std::string(w.reason, strnlen(w.reason, sizeof(w.reason)));
    run.reasons[li] = remote_reasons[li].empty() ? nullptr : remote_reasons[li].c_str();
  }
}

template <typename PointT>
void
DistributedLUM<PointT>::computeOn(Lum& lum,
                                  MPI_Comm comm,
                                  std::vector<std::string>& remote_reasons,
                                  const LinkOwner& owner)
{
  const std::string where = "[pcl_parallel::mpi::DistributedLUM::compute] ";
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  typename Lum::Run run;
  std::vector<int> owners; // of each link, in link order
  beginOn(lum, comm, run, owners, owner, where);

  std::vector<double> buffer;
  broadcastPoses(lum, comm, buffer, nullptr, 0); // rank 0's start poses
  // Gather layout: each rank's links in link order, the ranks in order; rank 0 puts each
  // block back at its link's place, so the system is assembled as in one process.
  const std::size_t num_links = run.links.size();
  std::vector<int> counts(size, 0), displs(size, 0);
  for (const int r : owners)
    counts[r] += static_cast<int>(sizeof(WireLink));
  for (int r = 1; r < size; ++r)
    displs[r] = displs[r - 1] + counts[r - 1];
  std::vector<WireLink> mine(run.mine.size()), all(rank == 0 ? num_links : 0);
  remote_reasons.assign(num_links, std::string());

  std::string error;
  for (int it = 0; it < lum.getMaxIterations(); ++it) {
    error.clear();
    try {
      lum.measureLinks(run, it); // steps 1-2, this rank's links
    }
    catch (const std::exception& e) {
      error = e.what();
    }
    throwIfAnyFailed(comm, error);
    packLinks(run, mine);
    MPI_Gatherv(mine.data(),
                counts[rank],
                MPI_BYTE,
                all.data(),
                counts.data(),
                displs.data(),
                MPI_BYTE,
                0,
                comm);
    // control: go on (1), stop (0) or failed on rank 0 (-1); then the counters.
    double control[4] = {0.0, 0.0, 0.0, 0.0};
    if (rank == 0) {
      try {
        unpackLinks(run, all, owners, displs, remote_reasons);
        control[0] = lum.solveIteration(run, it) ? 1.0 : 0.0; // steps 3-5
        control[1] = lum.iterations_done_;
        control[2] = lum.last_mean_update_;
        control[3] = static_cast<double>(lum.dropped_links_);
      }
      catch (const std::exception& e) {
        error = e.what();
        control[0] = -1.0;
      }
    }
    broadcastPoses(lum, comm, buffer, control, 4);
    if (control[0] < 0.0)
      throwIfAnyFailed(comm, rank == 0 ? error : std::string());
    lum.iterations_done_ = static_cast<int>(control[1]);
    lum.last_mean_update_ = control[2];
    lum.dropped_links_ = static_cast<std::size_t>(control[3]);
    if (control[0] == 0.0)
      break;
  }
  lum.endCompute(run);
}

} // namespace mpi
} // namespace pcl_parallel

#define PCL_INSTANTIATE_DistributedLUM(T) template class pcl_parallel::mpi::DistributedLUM<T>;
