/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/normal_estimation.h>
#include <pcl_parallel/reduction.h>
#include <pcl_parallel/registration/icp.h>
#include <pcl_parallel/registration/impl/correspondence_estimation.hpp>
#include <pcl_parallel/search/impl/kdtree.hpp>

#include <pcl/console/print.h>
#include <pcl/registration/transformation_estimation_svd.h>
#include <pcl/type_traits.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
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
  // force_no_recompute: the caller promises tree (and so normals) match the target.
  if (!force_no_recompute_)
    normals_valid_ = false;
  Base::setInputTarget(cloud);
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::setRobustKernel(
    const RobustKernel& kernel)
{
  if (kernel.type != RobustKernel::Type::kNone &&
      (!(kernel.scale > 0.0) || !std::isfinite(kernel.scale)))
    throw std::invalid_argument("[pcl_parallel::" + getClassName() +
                                "::setRobustKernel] the kernel scale must be positive and "
                                "finite, got " +
                                std::to_string(kernel.scale));
  kernel_ = kernel;
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::alignDouble(
    PointCloudSource& output, const Eigen::Matrix4d& guess)
{
  use_double_ = true;
  guess_double_ = guess;
  try {
    this->align(output, guess.template cast<Scalar>());
  }
  catch (...) {
    use_double_ = false;
    throw;
  }
  use_double_ = false;
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
      normals_valid_ = false;
    }
  }
  else {
    // A PCL tree from setSearchMethodTarget: leave it alone, search our own.
    if (!private_tree_ || private_tree_->getInputCloud() != target_) {
      private_tree_.reset(new TargetTree);
      private_tree_->setNumberOfThreads(num_threads_);
      private_tree_->setInputCloud(target_);
      normals_valid_ = false;
    }
    ours = private_tree_.get();
  }
  target_index_ = ours->sharedIndex();
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
  final_hessian_.setZero();
  final_error_ = final_weight_ = 0.0;
  if (used_fast_path_) {
    computeTransformationFused(output, guess);
    return;
  }
  if (point_to_plane_ || planar_ || kernel_.type != RobustKernel::Type::kNone)
    PCL_WARN("[pcl_parallel::%s::computeTransformation] A user component runs PCL's loop: "
             "point-to-plane, the planar mode and the robust kernel are ignored.\n",
             getClassName().c_str());
  if (criteria)
    criteria->clearCorrespondencesMSE();
  if (auto* ce = dynamic_cast<CorrespondenceEstimation*>(correspondence_estimation_.get()))
    ce->setNumberOfThreads(num_threads_);
  Base::computeTransformation(output, guess);
  final_transformation_double_ = final_transformation_.template cast<double>();
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::updateTargetNormals(
    const KdTreeIndex& target)
{
  // Held, so a later index cannot reuse the address; a new index means new normals.
  if (normals_valid_ && normals_index_.get() == &target &&
      target_normals_.size() == 3 * target.size())
    return;
  normals_index_ = target_index_.get() == &target ? target_index_ : nullptr;
  normals_valid_ = true;
  if constexpr (pcl::traits::has_normal_v<PointTarget>) {
    if (use_normal_fields_) {
      // The target's own normals, copied into tree order (contiguous per leaf): a gather
      // over a whole local map (300k points) each time it changes, so in parallel.
      const PointCloudTarget& tgt = *target_;
      target_normals_.resize(3 * target.size());
      const std::size_t n = target.size();
      const unsigned threads = n > 20000 ? resolveNumberOfThreads(num_threads_) : 1;
      parallelFor(n, threads, evenGrain(n, threads), [&](std::size_t first, std::size_t last) {
        for (std::size_t pos = first; pos < last; ++pos) {
          const auto& p = tgt[target.id(static_cast<std::uint32_t>(pos))];
          target_normals_[3 * pos] = p.normal_x;
          target_normals_[3 * pos + 1] = p.normal_y;
          target_normals_[3 * pos + 2] = p.normal_z;
        }
      });
      return;
    }
  }
  if (planar_) { // a 2D scan's points: normals in its plane, normal to the walls' lines
    const std::vector<Eigen::Vector3f> unit =
        estimateUnitNormals(target, normal_k_, num_threads_, Eigen::Vector3f::UnitZ());
    target_normals_.assign(3 * unit.size(), std::numeric_limits<float>::quiet_NaN());
    for (std::size_t pos = 0; pos < unit.size(); ++pos)
      if (!unit[pos].isZero()) // zero: no line there
        Eigen::Vector3f::Map(&target_normals_[3 * pos]) = unit[pos];
    return;
  }
  estimateNormals(target, normal_k_, num_threads_, target_normals_);
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::setMotionPrior(
    const Eigen::Matrix4d& prior, double weight_translation, double weight_rotation)
{
  if (!(weight_translation >= 0.0) || !(weight_rotation >= 0.0) ||
      !std::isfinite(weight_translation) || !std::isfinite(weight_rotation) ||
      !prior.allFinite())
    throw std::invalid_argument("[pcl_parallel::ParallelIterativeClosestPoint::setMotionPrior] "
                                "weights must be finite and >= 0, the prior finite");
  prior_ = prior;
  prior_weight_t_ = weight_translation;
  prior_weight_r_ = weight_rotation;
}

template <typename PointSource, typename PointTarget, typename Scalar>
bool
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::fusedStep(
    const KdTreeIndex& target,
    const SearchTransform& tr,
    Eigen::Matrix4d& step,
    double& pairs,
    double& mse)
{
  const unsigned threads = resolveNumberOfThreads(num_threads_);
  const float bound = sqrDistanceBound(corr_dist_threshold_);
  // Per thread: its padded search slot (paper Sec. IV-B) and a block's pair buffer.
  std::vector<NearestSlot> slots(threads);
  pair_buffers_.resize(threads);

  if (!point_to_plane_) {
    const PointToPointMoments total = pointToPointPass(target, tr, bound, slots);
    pairs = total.n;
    mse = total.n > 0 ? total.sqr_dist / total.n : 0.0;
    if (total.n < static_cast<double>(min_number_correspondences_) || !(total.w > 0.0))
      return true; // the caller reports too few pairs
    step = planar_ ? PointToPointFactor::solvePlanar(total)
                   : PointToPointFactor::solve(
                         total, rotation_method_ == RotationMethod::kHornQuaternion);
    return true;
  }

  // Point-to-plane: normal equations in coordinates shifted by a target point.
  updateTargetNormals(target);
  const float* r = target.point(0);
  const double ref[3] = {r[0], r[1], r[2]};
  const NormalEquations total = pointToPlanePass(target, tr, bound, ref, slots);
  pairs = total.n;
  mse = total.n > 0 ? total.sqr_dist / total.n : 0.0;
  if (total.n < static_cast<double>(min_number_correspondences_))
    return true;
  return solvePointToPlane(total, ref, step);
}

template <typename PointSource, typename PointTarget, typename Scalar>
PointToPointMoments
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::pointToPointPass(
    const KdTreeIndex& target,
    const SearchTransform& tr,
    float bound,
    std::vector<NearestSlot>& slots)
{
  const PointCloudSource& src = *input_;
  const RobustKernel kernel = kernel_;
  const std::vector<PointToPointMoments> children = deterministicBlocks(
      order_.size(),
      static_cast<unsigned>(slots.size()),
      PointToPointMoments{},
      [&](std::size_t begin, std::size_t end, unsigned t) {
        NearestSlot& slot = slots[t];
        std::vector<MatchedPair>& buf = pair_buffers_[t];
        buf.clear();
        double sqr_dist = 0.0;
        MatchedPair pair;
        for (std::size_t i = begin; i < end; ++i) {
          const std::uint32_t pos = transformedNearest(
              target, slot, tr, src[order_[i]].data, pair.d, bound, warm_[i]);
          if (pos == KdTreeIndex::kInvalid)
            continue;
          warm_[i] = pos;
          pair.m = target.point(pos);
          pair.w = kernel.weight(slot.sqr_dist);
          sqr_dist += slot.sqr_dist;
          buf.push_back(pair);
        }
        return PointToPointFactor::child(buf.data(), buf.size(), sqr_dist);
      });
  return PointToPointFactor::combine(children);
}

template <typename PointSource, typename PointTarget, typename Scalar>
NormalEquations
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::pointToPlanePass(
    const KdTreeIndex& target,
    const SearchTransform& tr,
    float bound,
    const double ref[3],
    std::vector<NearestSlot>& slots)
{
  const PointCloudSource& src = *input_;
  const RobustKernel kernel = kernel_;
  return deterministicReduce(
      order_.size(),
      static_cast<unsigned>(slots.size()),
      NormalEquations{},
      [&](std::size_t begin, std::size_t end, unsigned t) {
        NormalEquations acc;
        NearestSlot& slot = slots[t];
        float q[3];
        for (std::size_t i = begin; i < end; ++i) {
          const std::uint32_t pos =
              transformedNearest(target, slot, tr, src[order_[i]].data, q, bound, warm_[i]);
          if (pos == KdTreeIndex::kInvalid)
            continue;
          warm_[i] = pos;
          const float* nrm = &target_normals_[3 * static_cast<std::size_t>(pos)];
          if (!std::isfinite(nrm[0]) || !std::isfinite(nrm[1]) || !std::isfinite(nrm[2]))
            continue; // no plane there (PCL's LLS would turn the pair into NaN)
          const float* m = target.point(pos);
          const double dd[3] = {q[0] - ref[0], q[1] - ref[1], q[2] - ref[2]};
          const double mm[3] = {m[0] - ref[0], m[1] - ref[1], m[2] - ref[2]};
          acc.n += 1.0;
          acc.sqr_dist += slot.sqr_dist;
          acc.add(dd, mm, nrm, kernel);
        }
        return acc;
      },
      [](NormalEquations& into, const NormalEquations& from) { into += from; });
}

template <typename PointSource, typename PointTarget, typename Scalar>
bool
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::solvePointToPlane(
    const NormalEquations& total, const double ref[3], Eigen::Matrix4d& step)
{
  // The pairs' information alone (no prior), at the estimate they were found at.
  final_hessian_ = PointToPlaneFactor::bodyHessian(total, ref, final_transformation_double_);
  final_error_ = total.rtr;
  final_weight_ = total.w;
  const auto solve = planar_ ? &PointToPlaneFactor::solvePlanar : &PointToPlaneFactor::solve;
  if (prior_weight_t_ > 0.0 || prior_weight_r_ > 0.0) {
    NormalEquations with_prior = total;
    PointToPlaneFactor::addPosePrior(with_prior,
                                     ref,
                                     final_transformation_double_,
                                     prior_,
                                     prior_weight_t_,
                                     prior_weight_r_);
    return solve(with_prior, ref, step);
  }
  return solve(total, ref, step);
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::setUpCriteria(
    ConvergenceCriteria& criteria) const
{
  // Same criteria set-up as PCL's computeTransformation.
  criteria.setMaximumIterations(max_iterations_);
  criteria.setRelativeMSE(euclidean_fitness_epsilon_);
  criteria.setTranslationThreshold(transformation_epsilon_);
  if (transformation_rotation_epsilon_ > 0)
    criteria.setRotationThreshold(transformation_rotation_epsilon_);
  else
    criteria.setRotationThreshold(1.0 - transformation_epsilon_);
}

template <typename PointSource, typename PointTarget, typename Scalar>
void
ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>::applyStep(
    const Eigen::Matrix4d& step)
{
  transformation_ = step.template cast<Scalar>();
  if (use_double_) {
    final_transformation_double_ = step * final_transformation_double_;
    final_transformation_ = final_transformation_double_.template cast<Scalar>();
  }
  else {
    final_transformation_ = transformation_ * final_transformation_;
    final_transformation_double_ = final_transformation_.template cast<double>();
  }
  ++nr_iterations_;
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
  setUpCriteria(criteria);

  final_transformation_double_ =
      use_double_ ? guess_double_ : Eigen::Matrix4d(guess.template cast<double>());
  const KdTreeIndex* target = targetIndex();
  if (target) {
    const PointCloudSource& src = *input_;
    // Finite source points in spatial order (coherent tree walks); NaNs are left out here.
    detail::spatialOrder(src.empty() ? nullptr : src.front().data,
                         src.size(),
                         sizeof(PointSource) / sizeof(float),
                         order_);
    warm_.assign(order_.size(), KdTreeIndex::kInvalid);

    do {
      previous_transformation_ = transformation_;
      // The search runs in float on the current estimate (composed in double after
      // alignDouble, in Scalar as PCL otherwise).
      const SearchTransform tr = use_double_
                                     ? SearchTransform::from(final_transformation_double_)
                                     : SearchTransform::from(final_transformation_);
      Eigen::Matrix4d step = Eigen::Matrix4d::Identity();
      double pairs = 0.0, mse = 0.0;
      const bool solved = fusedStep(*target, tr, step, pairs, mse);

      if (pairs < static_cast<double>(min_number_correspondences_)) {
        PCL_ERROR("[pcl_parallel::%s::computeTransformation] Not enough correspondences "
                  "found (%.0f). Relax your threshold parameters.\n",
                  getClassName().c_str(),
                  pairs);
        criteria.setConvergenceState(State::CONVERGENCE_CRITERIA_NO_CORRESPONDENCES);
        converged_ = false;
        break;
      }
      if (!solved) {
        PCL_ERROR("[pcl_parallel::%s::computeTransformation] The point-to-plane system of "
                  "%.0f pairs is singular (too few independent normals).\n",
                  getClassName().c_str(),
                  pairs);
        criteria.setConvergenceState(State::CONVERGENCE_CRITERIA_NO_CORRESPONDENCES);
        converged_ = false;
        break;
      }

      applyStep(step);

      // PCL's MSE: mean of the correspondences' squared distances.
      criteria.setCorrespondencesMSE(mse);
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
