/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/registration/correspondence_estimation.h>
#include <pcl_parallel/search/impl/kdtree.hpp>

#include <pcl/console/print.h>

namespace pcl_parallel {
namespace registration {

template <typename PointSource, typename PointTarget, typename Scalar>
ParallelCorrespondenceEstimation<PointSource, PointTarget, Scalar>::
    ParallelCorrespondenceEstimation()
{
  corr_name_ = "ParallelCorrespondenceEstimation";
  tree_.reset(new TargetTree);
}

template <typename PointSource, typename PointTarget, typename Scalar>
const KdTreeIndex*
ParallelCorrespondenceEstimation<PointSource, PointTarget, Scalar>::targetIndex()
{
  if (!target_) {
    PCL_ERROR("[pcl_parallel::%s] No input target dataset was given!\n", corr_name_.c_str());
    return nullptr;
  }
  auto* ours = dynamic_cast<TargetTree*>(tree_.get());
  if (ours) {
    // PCL semantics: rebuild when the target (or the tree) changed, unless the user
    // promised with force_no_recompute that the tree is already built on it.
    if (target_cloud_updated_ && !force_no_recompute_) {
      ours->setNumberOfThreads(num_threads_);
      ours->setInputCloud(target_, target_indices_);
    }
  }
  else {
    if (target_cloud_updated_ || !private_target_tree_) {
      private_target_tree_.reset(new TargetTree);
      private_target_tree_->setNumberOfThreads(num_threads_);
      private_target_tree_->setInputCloud(target_, target_indices_);
    }
    ours = private_target_tree_.get();
  }
  target_cloud_updated_ = false;
  if (ours->index().empty()) {
    PCL_ERROR("[pcl_parallel::%s] The target search tree holds no points (empty or "
              "all-NaN target, or force_no_recompute on a tree never built).\n",
              corr_name_.c_str());
    return nullptr;
  }
  return &ours->index();
}

template <typename PointSource, typename PointTarget, typename Scalar>
const KdTreeIndex*
ParallelCorrespondenceEstimation<PointSource, PointTarget, Scalar>::initSearch()
{
  // PCLBase's own checks (input set, indices valid); not Base::initCompute(), which would
  // rebuild PCL's FLANN tree that we do not search.
  if (!pcl::PCLBase<PointSource>::initCompute())
    return nullptr;
  return targetIndex();
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
ParallelCorrespondenceEstimation<PointSource, PointTarget, Scalar>::matchSource(
    const KdTreeIndex& target,
    double max_distance,
    std::vector<std::uint32_t>& match,
    std::vector<float>& sqr_dist) const
{
  const std::size_t n = indices_->size();
  const unsigned threads = resolveNumberOfThreads(num_threads_);
  std::vector<float> queries(3 * n);
  parallelFor(n, threads, evenGrain(n, threads), [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i)
      std::copy_n((*input_)[(*indices_)[i]].data, 3, &queries[3 * i]);
  });
  match.resize(n);
  sqr_dist.resize(n);
  target.nearestBatch(queries.data(),
                      n,
                      3,
                      sqrDistanceBound(max_distance),
                      match.data(),
                      sqr_dist.data(),
                      threads);
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
ParallelCorrespondenceEstimation<PointSource, PointTarget, Scalar>::determineCorrespondences(
    pcl::Correspondences& correspondences, double max_distance)
{
  correspondences.clear();
  const KdTreeIndex* target = initSearch();
  if (!target)
    return;
  std::vector<std::uint32_t> match;
  std::vector<float> sqr_dist;
  matchSource(*target, max_distance, match, sqr_dist);

  correspondences.reserve(match.size());
  for (std::size_t i = 0; i < match.size(); ++i)
    if (match[i] != KdTreeIndex::kInvalid)
      correspondences.emplace_back(
          (*indices_)[i], static_cast<pcl::index_t>(target->id(match[i])), sqr_dist[i]);
  this->deinitCompute();
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
ParallelCorrespondenceEstimation<PointSource, PointTarget, Scalar>::
    determineReciprocalCorrespondences(pcl::Correspondences& correspondences,
                                       double max_distance)
{
  correspondences.clear();
  const KdTreeIndex* target = initSearch();
  if (!target)
    return;
  // The source changes every ICP iteration, so PCL rebuilds its reciprocal tree each unless
  // force_no_recompute_reciprocal says it is current. call; we do the same unless
  // force_no_recompute_reciprocal says it is current. A new source cloud or index vector always
  // counts as a change.
  const bool same_source =
      source_key_ == std::make_tuple(input_.get(), indices_.get(), indices_->size());
  if ((source_cloud_updated_ && !force_no_recompute_reciprocal_) || !same_source ||
      source_index_.empty()) {
    search::detail::buildIndex(source_index_,
                               input_.get(),
                               indices_.get(),
                               num_threads_,
                               KdTreeIndex::kDefaultBucketSize);
    source_key_ = std::make_tuple(input_.get(), indices_.get(), indices_->size());
    source_cloud_updated_ = false;
  }
  std::vector<std::uint32_t> match;
  std::vector<float> sqr_dist;
  matchSource(*target, max_distance, match, sqr_dist);

  const float bound = sqrDistanceBound(max_distance);
  const std::size_t n = match.size();
  std::vector<char> keep(n, 0);
  const unsigned threads = resolveNumberOfThreads(num_threads_);
  parallelFor(n, threads, 256, [&](std::size_t first, std::size_t last) {
    NearestSlot slot; // on this thread's stack: nothing shared
    for (std::size_t i = first; i < last; ++i) {
      if (match[i] == KdTreeIndex::kInvalid)
        continue;
      slot.query = target->point(match[i]);
      const std::uint32_t back = source_index_.nearest(slot, bound);
      keep[i] = back != KdTreeIndex::kInvalid &&
                static_cast<pcl::index_t>(source_index_.id(back)) == (*indices_)[i];
    }
  });
  for (std::size_t i = 0; i < n; ++i)
    if (keep[i])
      correspondences.emplace_back(
          (*indices_)[i], static_cast<pcl::index_t>(target->id(match[i])), sqr_dist[i]);
  this->deinitCompute();
}

} // namespace registration
} // namespace pcl_parallel
