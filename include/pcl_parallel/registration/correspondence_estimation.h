/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/registration/mixed_point_types.h>
#include <pcl_parallel/search/kdtree.h>

#include <pcl/registration/correspondence_estimation.h>

#include <tuple>

namespace pcl_parallel {
namespace registration {

/**
 * \brief Closest-point correspondences computed in parallel (paper Sec. IV-A/B), as a
 * pcl::registration::CorrespondenceEstimationBase, so it plugs into any PCL registration
 * (setCorrespondenceEstimation) including pcl::IterativeClosestPoint.
 *
 * Results equal pcl::registration::CorrespondenceEstimation's: one correspondence per
 * source point (setIndicesSource order) whose closest target point (setIndicesTarget)
 * lies within max_distance, with PCL's convention that Correspondence::distance holds the
 * *squared* distance. Non-finite source points get no correspondence.
 *
 * Search structure: the target tree is tree_ if it is a pcl_parallel::search::KdTree
 * (the default), built when the target changes unless setSearchMethodTarget(tree, true)
 * said it is already built. A plain PCL tree passed to setSearchMethodTarget is left
 * untouched and a private pcl_parallel tree over the target is used instead. The
 * reciprocal search uses a private tree over the source.
 *
 * Unlike PCL 1.13's class it compiles for different source and target types (see
 * mixed_point_types.h).
 */
template <typename PointSource, typename PointTarget, typename Scalar = float>
class ParallelCorrespondenceEstimation
    : public pcl::registration::CorrespondenceEstimationBase<PointSource, PointTarget, Scalar> {
public:
  /** PCL's base class. */
  using Base =
      pcl::registration::CorrespondenceEstimationBase<PointSource, PointTarget, Scalar>;
  /** Shared pointer, as PCL's. */
  using Ptr =
      pcl::shared_ptr<ParallelCorrespondenceEstimation<PointSource, PointTarget, Scalar>>;
  /** Shared pointer to const, as PCL's. */
  using ConstPtr =
      pcl::shared_ptr<const ParallelCorrespondenceEstimation<PointSource, PointTarget, Scalar>>;
  /** The target tree type searched in parallel. */
  using TargetTree = pcl_parallel::search::KdTree<PointTarget>;

  ParallelCorrespondenceEstimation();
  ~ParallelCorrespondenceEstimation() override = default;

  /** PCL's determineCorrespondences, the closest-point queries in parallel; the same pairs in
   *  the same order as PCL's. */
  void
  determineCorrespondences(pcl::Correspondences& correspondences,
                           double max_distance = std::numeric_limits<double>::max()) override;

  /** Pairs that are each other's closest point (both searches within max_distance). */
  void
  determineReciprocalCorrespondences(
      pcl::Correspondences& correspondences,
      double max_distance = std::numeric_limits<double>::max()) override;

  /** A copy of this estimator, as PCL's clone(). */
  typename Base::Ptr
  clone() const override
  {
    return Ptr(new ParallelCorrespondenceEstimation(*this));
  }

  /** Threads for searching and tree building; 0 (default) = all cores. */
  void
  setNumberOfThreads(unsigned num_threads)
  {
    num_threads_ = num_threads;
  }
  /** Threads used (0: all cores). */
  unsigned
  getNumberOfThreads() const
  {
    return num_threads_;
  }

  /** The index the target is searched with (built if needed); null on error. */
  const KdTreeIndex*
  targetIndex();

protected:
  using Base::corr_name_;
  using Base::force_no_recompute_;
  using Base::force_no_recompute_reciprocal_;
  using Base::indices_;
  using Base::input_;
  using Base::source_cloud_updated_;
  using Base::target_;
  using Base::target_cloud_updated_;
  using Base::target_indices_;
  using Base::tree_;

  /** Source checks of PCLBase (creates indices_), then the target index; PCL_ERROR and
   *  null on failure. Does not touch PCL's trees. */
  const KdTreeIndex*
  initSearch();

  /** Nearest target point of every source point in indices_ order; kInvalid where none. */
  void
  matchSource(const KdTreeIndex& target,
              double max_distance,
              std::vector<std::uint32_t>& match,
              std::vector<float>& sqr_dist) const;

private:
  unsigned num_threads_ = 0;
  typename TargetTree::Ptr private_target_tree_; ///< used when tree_ is not ours
  KdTreeIndex source_index_;                     ///< reciprocal search over the source
  std::tuple<const void*, const void*, std::size_t> source_key_{}; ///< what it was built on
};

/** Largest float f with double(f) <= bound: comparing a float squared distance against
 *  it is exactly PCL's comparison `distance > max_dist_sqr` done in double. */
float
sqrDistanceBound(double max_distance);

} // namespace registration
} // namespace pcl_parallel

#ifdef PCL_NO_PRECOMPILE
#include <pcl_parallel/registration/impl/correspondence_estimation.hpp>
#endif
