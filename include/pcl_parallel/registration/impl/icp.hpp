/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/reduction.h>
#include <pcl_parallel/registration/icp.h>
#include <pcl_parallel/registration/impl/correspondence_estimation.hpp>
#include <pcl_parallel/search/impl/kdtree.hpp>

#include <pcl/console/print.h>
#include <pcl/registration/transformation_estimation_svd.h>

#include <omp.h>

#include <cmath>
#include <cstdint>
#include <typeinfo>

namespace pcl_parallel {
namespace registration {

template <typename Scalar>
bool
FusedConvergenceCriteria<Scalar>::hasConverged()
{
  if (!use_external_mse_)
    return Base::hasConverged();
  // PCL 1.13's DefaultConvergenceCriteria::hasConverged, rule for rule; only the MSE
  // comes from the fused pass instead of calculateMSE(correspondences_).
  using State = typename Base::ConvergenceState;
  if (this->convergence_state_ != State::CONVERGENCE_CRITERIA_NOT_CONVERGED) {
    this->iterations_similar_transforms_ = 0;
    this->convergence_state_ = State::CONVERGENCE_CRITERIA_NOT_CONVERGED;
  }
  bool is_similar = false;
  if (this->iterations_ >= this->max_iterations_) {
    if (!this->failure_after_max_iter_) {
      this->convergence_state_ = State::CONVERGENCE_CRITERIA_ITERATIONS;
      return true;
    }
    this->convergence_state_ = State::CONVERGENCE_CRITERIA_FAILURE_AFTER_MAX_ITERATIONS;
  }
  const Matrix4& tr = this->transformation_;
  const double cos_angle = 0.5 * (tr.coeff(0, 0) + tr.coeff(1, 1) + tr.coeff(2, 2) - 1);
  const double translation_sqr = tr.coeff(0, 3) * tr.coeff(0, 3) +
                                 tr.coeff(1, 3) * tr.coeff(1, 3) +
                                 tr.coeff(2, 3) * tr.coeff(2, 3);
  if (cos_angle >= this->rotation_threshold_ &&
      translation_sqr <= this->translation_threshold_) {
    if (this->iterations_similar_transforms_ >= this->max_iterations_similar_transforms_) {
      this->convergence_state_ = State::CONVERGENCE_CRITERIA_TRANSFORM;
      return true;
    }
    is_similar = true;
  }
  this->correspondences_cur_mse_ = external_mse_;
  const double diff =
      std::abs(this->correspondences_cur_mse_ - this->correspondences_prev_mse_);
  if (diff < this->mse_threshold_absolute_) {
    if (this->iterations_similar_transforms_ >= this->max_iterations_similar_transforms_) {
      this->convergence_state_ = State::CONVERGENCE_CRITERIA_ABS_MSE;
      return true;
    }
    is_similar = true;
  }
  if (diff / this->correspondences_prev_mse_ < this->mse_threshold_relative_) {
    if (this->iterations_similar_transforms_ >= this->max_iterations_similar_transforms_) {
      this->convergence_state_ = State::CONVERGENCE_CRITERIA_REL_MSE;
      return true;
    }
    is_similar = true;
  }
  if (is_similar)
    ++this->iterations_similar_transforms_;
  else
    this->iterations_similar_transforms_ = 0;
  this->correspondences_prev_mse_ = this->correspondences_cur_mse_;
  return false;
}

template <typename PointSource, typename PointTarget, typename Scalar>
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::ParallelIterativeClosestPoint()
{
  reg_name_ = "ParallelIterativeClosestPoint";
  // Our tree as the registration's target tree: Registration::initCompute then builds
  // it (in parallel) instead of FLANN's, and the fused pass reuses its index.
  tree_.reset(new TargetTree);
  correspondence_estimation_.reset(new CorrespondenceEstimation);
  this->convergence_criteria_.reset(
      new ConvergenceCriteria(nr_iterations_, transformation_, *correspondences_));
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::setNumberOfThreads(
    unsigned num_threads)
{
  num_threads_ = num_threads;
  if (auto* t = dynamic_cast<TargetTree*>(tree_.get()))
    t->setNumberOfThreads(num_threads);
  if (auto* ce = dynamic_cast<CorrespondenceEstimation*>(correspondence_estimation_.get()))
    ce->setNumberOfThreads(num_threads);
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::setInputTarget(
    const PointCloudTargetConstPtr& cloud)
{
  private_tree_.reset();
  Base::setInputTarget(cloud);
}

template <typename PointSource, typename PointTarget, typename Scalar>
const KdTreeIndex*
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::targetIndex()
{
  if (!target_) {
    PCL_ERROR("[pcl_parallel::%s] No input target dataset was given!\n",
              getClassName().c_str());
    return nullptr;
  }
  TargetTree* ours = dynamic_cast<TargetTree*>(tree_.get());
  if (ours) {
    // PCL semantics: rebuild for a new target unless force_no_recompute promised the
    // tree is current (Registration::initCompute normally did it already).
    if (!force_no_recompute_ && (target_cloud_updated_ || ours->getInputCloud() != target_)) {
      ours->setNumberOfThreads(num_threads_);
      ours->setInputCloud(target_);
      target_cloud_updated_ = false;
    }
  }
  else {
    // A PCL tree from setSearchMethodTarget: leave it alone, search our own.
    if (!private_tree_ || private_tree_->getInputCloud() != target_) {
      private_tree_.reset(new TargetTree);
      private_tree_->setNumberOfThreads(num_threads_);
      private_tree_->setInputCloud(target_);
    }
    ours = private_tree_.get();
  }
  if (ours->index().empty()) {
    PCL_ERROR("[pcl_parallel::%s] The target search tree holds no points (empty or "
              "all-NaN target, or force_no_recompute on a tree never built).\n",
              getClassName().c_str());
    return nullptr;
  }
  return &ours->index();
}

template <typename PointSource, typename PointTarget, typename Scalar>
bool
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::fastPathApplies() const
{
  using DefaultTE =
      pcl::registration::TransformationEstimationSVD<PointSource, PointTarget, Scalar>;
  const auto* ce = correspondence_estimation_.get();
  const auto* te = transformation_estimation_.get();
  // Exact types: a subclass of either may change what is computed.
  return ce && te && typeid(*ce) == typeid(CorrespondenceEstimation) &&
         typeid(*te) == typeid(DefaultTE) && correspondence_rejectors_.empty() &&
         !use_reciprocal_correspondence_ && update_visualizer_ == nullptr;
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::computeTransformation(
    PointCloudSource& output, const Matrix4& guess)
{
  auto* criteria = dynamic_cast<ConvergenceCriteria*>(this->convergence_criteria_.get());
  used_fast_path_ = criteria && fastPathApplies();
  if (used_fast_path_) {
    computeTransformationFused(output, guess);
    return;
  }
  if (criteria)
    criteria->clearCorrespondencesMSE();
  if (auto* ce = dynamic_cast<CorrespondenceEstimation*>(correspondence_estimation_.get()))
    ce->setNumberOfThreads(num_threads_);
  Base::computeTransformation(output, guess);
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::computeTransformationFused(
    PointCloudSource& output, const Matrix4& guess)
{
  using State =
      typename pcl::registration::DefaultConvergenceCriteria<Scalar>::ConvergenceState;
  auto& criteria = static_cast<ConvergenceCriteria&>(*this->convergence_criteria_);

  nr_iterations_ = 0;
  converged_ = false;
  final_transformation_ = guess;
  transformation_ = Matrix4::Identity();
  correspondences_->clear();

  // Same criteria set-up as PCL's computeTransformation.
  criteria.setMaximumIterations(max_iterations_);
  criteria.setRelativeMSE(euclidean_fitness_epsilon_);
  criteria.setTranslationThreshold(transformation_epsilon_);
  if (transformation_rotation_epsilon_ > 0)
    criteria.setRotationThreshold(transformation_rotation_epsilon_);
  else
    criteria.setRotationThreshold(1.0 - transformation_epsilon_);

  const KdTreeIndex* target = targetIndex();
  if (target) {
    const PointCloudSource& src = *input_;
    // Finite source points in spatial order (coherent tree walks); NaNs are left out here.
    detail::spatialOrder(src.empty() ? nullptr : src.front().data,
                         src.size(),
                         sizeof(PointSource) / sizeof(float),
                         order_);
    const std::size_t n = order_.size();
    const unsigned threads = resolveNumberOfThreads(num_threads_);
    const float bound = sqrDistanceBound(corr_dist_threshold_);
    // A target point as reference: shifted sums stay small (Eq. 11-13 in double).
    const float* r = target->point(0);
    const double ref[3] = {r[0], r[1], r[2]};
    warm_.assign(n, KdTreeIndex::kInvalid);
    // Paper Sec. IV-B: one padded search slot per thread, indexed by thread number.
    std::vector<NearestSlot> slots(threads);

    do {
      previous_transformation_ = transformation_;
      // Row-major float copy of the current estimate (the search runs in float).
      float tr[12];
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
          tr[4 * r + c] = static_cast<float>(final_transformation_(r, c));

      // One fused parallel pass: transform, closest point (warm start), moments.
      auto block = [&](std::size_t begin, std::size_t end) {
        detail::PairMoments acc;
        NearestSlot& slot = slots[static_cast<std::size_t>(omp_get_thread_num()) % threads];
        float q[3];
        slot.query = q;
        for (std::size_t i = begin; i < end; ++i) {
          const auto& p = src[order_[i]];
          for (int r = 0; r < 3; ++r)
            q[r] = tr[4 * r] * p.x + tr[4 * r + 1] * p.y + tr[4 * r + 2] * p.z + tr[4 * r + 3];
          const std::uint32_t pos = target->nearest(slot, bound, warm_[i]);
          if (pos == KdTreeIndex::kInvalid)
            continue;
          warm_[i] = pos;
          const float* m = target->point(pos);
          const double dd[3] = {q[0] - ref[0], q[1] - ref[1], q[2] - ref[2]};
          const double mm[3] = {m[0] - ref[0], m[1] - ref[1], m[2] - ref[2]};
          acc.n += 1.0;
          acc.sqr_dist += slot.sqr_dist;
          for (int a = 0; a < 3; ++a) {
            acc.sd[a] += dd[a];
            acc.sm[a] += mm[a];
            for (int b = 0; b < 3; ++b)
              acc.sdm[3 * a + b] += dd[a] * mm[b];
          }
        }
        return acc;
      };
      auto combine = [](detail::PairMoments& into, const detail::PairMoments& from) {
        into.n += from.n;
        into.sqr_dist += from.sqr_dist;
        for (int a = 0; a < 3; ++a) {
          into.sd[a] += from.sd[a];
          into.sm[a] += from.sm[a];
        }
        for (int k = 0; k < 9; ++k)
          into.sdm[k] += from.sdm[k];
      };
      const detail::PairMoments total =
          deterministicReduce(n, threads, detail::PairMoments{}, block, combine);

      if (total.n < static_cast<double>(min_number_correspondences_)) {
        PCL_ERROR("[pcl_parallel::%s::computeTransformation] Not enough correspondences "
                  "found (%.0f). Relax your threshold parameters.\n",
                  getClassName().c_str(),
                  total.n);
        criteria.setConvergenceState(State::CONVERGENCE_CRITERIA_NO_CORRESPONDENCES);
        converged_ = false;
        break;
      }

      transformation_ = detail::rigidTransformFromMoments(
                            total, ref, rotation_method_ == RotationMethod::kHornQuaternion)
                            .template cast<Scalar>();
      final_transformation_ = transformation_ * final_transformation_;
      ++nr_iterations_;

      // PCL's MSE: mean of the correspondences' squared distances.
      criteria.setCorrespondencesMSE(total.sqr_dist / total.n);
      converged_ = static_cast<bool>(criteria);
    } while (criteria.getConvergenceState() == State::CONVERGENCE_CRITERIA_NOT_CONVERGED);
  }
  else {
    criteria.setConvergenceState(State::CONVERGENCE_CRITERIA_NO_CORRESPONDENCES);
    converged_ = false;
  }

  // As PCL: the output is the whole input, transformed (XYZ and normals).
  output = *input_;
  this->transformCloud(*input_, output, final_transformation_);
}

template <typename PointSource, typename PointTarget, typename Scalar>
double
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::getFitnessScore(
    double max_range)
{
  if (!input_) {
    PCL_ERROR("[pcl_parallel::%s::getFitnessScore] No input source.\n", getClassName().c_str());
    return std::numeric_limits<double>::max();
  }
  const KdTreeIndex* target = targetIndex();
  if (!target)
    return std::numeric_limits<double>::max();
  const PointCloudSource& src = *input_;
  const unsigned threads = resolveNumberOfThreads(num_threads_);
  // PCL transforms with the Scalar matrix, then searches without a distance limit and
  // keeps squared distances <= max_range.
  const Eigen::Matrix4f tr = final_transformation_.template cast<float>();
  struct Sum {
    double sum = 0.0;
    double count = 0.0;
  };
  const Sum total = deterministicReduce(
      src.size(),
      threads,
      Sum{},
      [&](std::size_t begin, std::size_t end) {
        Sum s;
        NearestSlot slot;
        float q[3];
        slot.query = q;
        for (std::size_t i = begin; i < end; ++i) {
          const auto& p = src[i];
          if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
            continue;
          const Eigen::Vector4f d = tr * Eigen::Vector4f(p.x, p.y, p.z, 1.0f);
          q[0] = d[0];
          q[1] = d[1];
          q[2] = d[2];
          if (target->nearest(slot, std::numeric_limits<float>::infinity()) ==
              KdTreeIndex::kInvalid)
            continue;
          if (slot.sqr_dist <= max_range) {
            s.sum += slot.sqr_dist;
            s.count += 1.0;
          }
        }
        return s;
      },
      [](Sum& into, const Sum& from) {
        into.sum += from.sum;
        into.count += from.count;
      });
  if (total.count > 0)
    return total.sum / total.count;
  return std::numeric_limits<double>::max();
}

} // namespace registration
} // namespace pcl_parallel
