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
DistributedLUM<PointT>::configHash() const
{
  std::uint64_t h = 14695981039346656037ull; // FNV-1a
  auto add = [&h](const auto& value) {
    unsigned char bytes[sizeof(value)];
    std::memcpy(bytes, &value, sizeof(value));
    for (unsigned char b : bytes)
      h = (h ^ b) * 1099511628211ull;
  };
  add(static_cast<std::uint64_t>(lum_.getNumVertices()));
  for (const auto& l : lum_.collectLinks()) {
    add(static_cast<std::uint64_t>(l.source));
    add(static_cast<std::uint64_t>(l.target));
  }
  add(lum_.max_iterations_);
  add(lum_.convergence_threshold_);
  add(lum_.correspondence_distance_);
  add(lum_.final_correspondence_distance_);
  add(lum_.correspondence_distance_factor_);
  add(static_cast<int>(lum_.point_to_plane_));
  add(lum_.point_to_point_weight_);
  add(static_cast<std::uint64_t>(lum_.normal_neighbours_));
  add(lum_.link_iterations_);
  add(static_cast<std::uint64_t>(lum_.min_correspondences_));
  add(static_cast<int>(lum_.symmetric_));
  add(static_cast<std::uint64_t>(lum_.query_step_));
  return h;
}

template <typename PointT>
void
DistributedLUM<PointT>::broadcastPoses(std::vector<double>& buffer,
                                       double* control,
                                       int num_control)
{
  const std::size_t n = lum_.poses_.size();
  buffer.resize(16 * n + static_cast<std::size_t>(num_control));
  if (rank_ == 0) {
    for (std::size_t v = 0; v < n; ++v)
      Eigen::Matrix4d::Map(&buffer[16 * v]) = lum_.poses_[v];
    std::copy(control, control + num_control, buffer.begin() + 16 * n);
  }
  MPI_Bcast(buffer.data(), static_cast<int>(buffer.size()), MPI_DOUBLE, 0, comm_);
  if (rank_ != 0) {
    for (std::size_t v = 0; v < n; ++v)
      lum_.poses_[v] = Eigen::Matrix4d::Map(&buffer[16 * v]);
    std::copy(buffer.begin() + 16 * n, buffer.end(), control);
  }
}

template <typename PointT>
std::uint64_t
DistributedLUM<PointT>::getBytesPerIteration() const
{
  const std::size_t rank0_links = linkRange(num_links_, 0, size_).second;
  return (num_links_ - rank0_links) * sizeof(WireLink) + static_cast<std::uint64_t>(size_ - 1) *
                                                             (16 * lum_.getNumVertices() + 4) *
                                                             sizeof(double);
}

template <typename PointT>
void
DistributedLUM<PointT>::compute()
{
  const std::string where = "[pcl_parallel::mpi::DistributedLUM::compute] ";
  typename Lum::Run run;
  const auto [begin, end] = owned_;
  std::string error;
  try {
    if (!(lum_.getCorrespondenceDistance() > 0.0))
      throw std::invalid_argument(where + "needs pLUM mode (setCorrespondenceDistance)");
    lum_.beginCompute(run, begin, end);
  }
  catch (const std::exception& e) {
    error = e.what();
  }
  throwIfAnyFailed(comm_, error);
  // Every rank must run the same relaxation (only the thread count may differ).
  const std::uint64_t hash = configHash();
  std::uint64_t lo = 0, hi = 0;
  MPI_Allreduce(&hash, &lo, 1, MPI_UINT64_T, MPI_MIN, comm_);
  MPI_Allreduce(&hash, &hi, 1, MPI_UINT64_T, MPI_MAX, comm_);
  if (lo != hi)
    throw std::runtime_error(where + "the graph or the pLUM options differ between ranks");

  std::vector<double> buffer;
  broadcastPoses(buffer, nullptr, 0); // rank 0's start poses
  // Gather layout: each rank's contiguous links, in rank order = link order.
  std::vector<int> counts(size_), displs(size_);
  for (int r = 0; r < size_; ++r) {
    const auto range = linkRange(num_links_, r, size_);
    counts[r] = static_cast<int>((range.second - range.first) * sizeof(WireLink));
    displs[r] = static_cast<int>(range.first * sizeof(WireLink));
  }
  std::vector<WireLink> mine(end - begin), all(rank_ == 0 ? num_links_ : 0);
  remote_reasons_.assign(num_links_, std::string());

  for (int it = 0; it < lum_.getMaxIterations(); ++it) {
    error.clear();
    try {
      lum_.measureLinks(run, it, begin, end); // steps 1-2, this rank's links
    }
    catch (const std::exception& e) {
      error = e.what();
    }
    throwIfAnyFailed(comm_, error);
    for (std::size_t li = begin; li < end; ++li) {
      const lum::LinkBlock& b = run.blocks[li];
      WireLink& w = mine[li - begin];
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
    MPI_Gatherv(mine.data(),
                counts[rank_],
                MPI_BYTE,
                all.data(),
                counts.data(),
                displs.data(),
                MPI_BYTE,
                0,
                comm_);
    // control: go on (1), stop (0) or failed on rank 0 (-1); then the counters.
    double control[4] = {0.0, 0.0, 0.0, 0.0};
    if (rank_ == 0) {
      try {
        for (std::size_t li = end; li < num_links_; ++li) { // rank 0 owns [0, end)
          const WireLink& w = all[li];
          lum::LinkBlock& b = run.blocks[li];
          b.info = Eigen::Map<const lum::Matrix6d>(w.info);
          b.grad = Eigen::Map<const lum::Vector6d>(w.grad);
          b.source = w.source;
          b.target = w.target;
          b.valid = w.valid != 0;
          run.pair_counts[li] = w.pairs;
          remote_reasons_[li] = std::string(w.reason, strnlen(w.reason, sizeof(w.reason)));
          run.reasons[li] = remote_reasons_[li].empty() ? nullptr : remote_reasons_[li].c_str();
        }
        control[0] = lum_.solveIteration(run, it) ? 1.0 : 0.0; // steps 3-5
        control[1] = lum_.iterations_done_;
        control[2] = lum_.last_mean_update_;
        control[3] = static_cast<double>(lum_.dropped_links_);
      }
      catch (const std::exception& e) {
        error = e.what();
        control[0] = -1.0;
      }
    }
    broadcastPoses(buffer, control, 4);
    if (control[0] < 0.0)
      throwIfAnyFailed(comm_, rank_ == 0 ? error : std::string());
    lum_.iterations_done_ = static_cast<int>(control[1]);
    lum_.last_mean_update_ = control[2];
    lum_.dropped_links_ = static_cast<std::size_t>(control[3]);
    if (control[0] == 0.0)
      break;
  }
  lum_.endCompute(run);
}

} // namespace mpi
} // namespace pcl_parallel

#define PCL_INSTANTIATE_DistributedLUM(T) template class pcl_parallel::mpi::DistributedLUM<T>;
