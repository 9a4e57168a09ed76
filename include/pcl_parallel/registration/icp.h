/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/registration/correspondence_estimation.h>
#include <pcl_parallel/registration/icp_factors.h>
#include <pcl_parallel/registration/mixed_point_types.h>
#include <pcl_parallel/search/kdtree.h>
#include <pcl_parallel/search/transformed_nearest.h>

#include <pcl/registration/default_convergence_criteria.h>
#include <pcl/registration/icp.h>

#include <limits>
#include <vector>

namespace pcl_parallel {
namespace registration {

/**
 * \brief PCL's DefaultConvergenceCriteria whose correspondence MSE can be supplied by the
 * caller instead of being summed from a correspondence vector.
 *
 * The fused pICP pass never materialises correspondences; it computes the MSE of the
 * (squared) correspondence distances itself and hands it over with
 * setCorrespondencesMSE(). hasConverged() is PCL 1.13's rule for rule (same members, same
 * order, same state carried across align() calls), so iteration counts and
 * getConvergenceState() mean exactly what they mean for pcl::IterativeClosestPoint.
 * Without a supplied MSE (the PCL loop) it is PCL's class unchanged.
 */
template <typename Scalar = float>
class FusedConvergenceCriteria : public pcl::registration::DefaultConvergenceCriteria<Scalar> {
public:
  /** PCL's criteria this extends. */
  using Base = pcl::registration::DefaultConvergenceCriteria<Scalar>;
  /** Transform matrix type. */
  using Matrix4 = typename Base::Matrix4;
  /** Shared pointer. */
  using Ptr = pcl::shared_ptr<FusedConvergenceCriteria<Scalar>>;

  /** Criteria over the registration's iteration count, transform and correspondences, as PCL's.
   */
  FusedConvergenceCriteria(const int& iterations,
                           const Matrix4& transform,
                           const pcl::Correspondences& correspondences)
      : Base(iterations, transform, correspondences)
  {}

  /** The MSE the next hasConverged() calls use instead of the correspondences'. */
  void
  setCorrespondencesMSE(double mse)
  {
    external_mse_ = mse;
    use_external_mse_ = true;
  }
  /** Back to PCL's behaviour: MSE from the correspondence vector. */
  void
  clearCorrespondencesMSE()
  {
    use_external_mse_ = false;
  }

  /** PCL 1.13's convergence rules in order, with the MSE the fused pass supplied. */
  bool
  hasConverged() override;

private:
  double external_mse_ = 0.0;
  bool use_external_mse_ = false;
};

/**
 * \brief Parallel ICP (pICP, paper Sec. II and IV): a drop-in replacement for
 * pcl::IterativeClosestPoint.
 *
 * It *is* a pcl::IterativeClosestPoint, so it goes wherever PCL takes a registration
 * (pcl::Registration::Ptr, ELCH::setReg, IncrementalRegistration::setRegistration) and
 * every setter of PCL's class keeps its meaning.
 *
 * **Fast path.** With PCL's default components (our parallel correspondence estimation,
 * no rejectors, TransformationEstimationSVD, no reciprocal correspondences, no
 * visualisation callback) each iteration is one parallel pass over fixed blocks of source
 * points (small_gicp's split: search, per-point factor, robust kernel, reduction):
 * - search (transformedNearest): every source point is transformed by the current
 *   estimate and its closest target point within the maximum distance is searched in our
 *   tree, warm-started from its match of the previous iteration. Source points are visited
 *   in Morton order (computed once per align()), so consecutive searches reuse the cached
 *   part of the tree; non-finite source points are skipped. No correspondence vector is
 *   built.
 * - factor: point-to-point (default, PCL's error) reduces each block to its pairs'
 *   centroids and H_i (paper Eq. 13) and combines the blocks by Eq. 12; the rotation comes
 *   from the SVD of H (Eq. 9, Arun's method with the reflection case handled) or, optionally,
 *   Horn's unit quaternion, the translation from Eq. 7. Point-to-plane
 *   (setUsePointToPlane) sums Gauss-Newton normal equations of the linearised rotation per
 *   block (PointToPlaneFactor), with target normals from the point type's normal fields or
 *   estimated in parallel (estimateNormals), both kept while the target is unchanged.
 * - robust kernel (setRobustKernel): Huber or Geman-McClure IRLS weights on the residuals,
 *   in the same pass (weighted centroids and H for point-to-point).
 * - reduction (deterministicBlocks): blocks of fixed size combined in a fixed order. The
 *   search result per point is exact, so the result is bit-identical for any thread count.
 * The iteration then follows PCL's order (incremental transform, final = incremental *
 * final, convergence check with PCL's DefaultConvergenceCriteria rules on the MSE of the
 * squared pair distances), so iteration counts match PCL's.
 *
 * **PCL loop.** With any user-supplied rejector, correspondence or transformation
 * estimator, reciprocal correspondences or a visualisation callback, PCL's own loop
 * (pcl::IterativeClosestPoint::computeTransformation) runs unchanged; the correspondence
 * estimation there is still our parallel one unless the user replaced it.
 *
 * **Target tree.** The default search method is a pcl_parallel::search::KdTree, so
 * Registration::initCompute builds our tree (once per target, as PCL) and the fast path
 * reuses its index; setSearchMethodTarget(tree, force_no_recompute) keeps PCL's meaning.
 * A plain PCL tree passed there is left alone and a private pcl_parallel tree is built.
 *
 * Documented differences from pcl::IterativeClosestPoint:
 * - The fast path transforms the original source by the accumulated transform each
 *   iteration (PCL re-transforms its float copy incrementally, accumulating rounding) and
 *   estimates in double (PCL's default SVD estimator works in Scalar): results agree to
 *   rounding, not bit for bit.
 * - As PCL's loop, the fast path uses every point of the input source (PCL's ICP does not
 *   honour setIndices for the correspondence search either).
 * - After a fast-path align() the registration's correspondence vector is left empty.
 * - Point-to-plane applies the solved rotation about the matched points' centroid where
 *   PCL's TransformationEstimationPointToPlaneLLS applies it about the origin: the same
 *   linear step and the same fixed point, steps differ at second order.
 * - Point-to-plane, the robust kernel and alignDouble act on the fast path only; PCL's loop
 *   (a user component) ignores them with a PCL_WARN.
 * - getFitnessScore() hides Registration::getFitnessScore (not virtual in PCL) with a
 *   parallel version on our tree; called through a pcl::Registration pointer, PCL's serial
 *   version runs (same value up to summation order).
 * - Fewer than min_number_correspondences (3) pairs: PCL_ERROR, hasConverged() == false,
 *   state CONVERGENCE_CRITERIA_NO_CORRESPONDENCES, final transform = the last estimate,
 *   output = source transformed by it. An empty or all-NaN target is reported the same way.
 */
template <typename PointSource, typename PointTarget, typename Scalar = float>
class ParallelIterativeClosestPoint
    : public pcl::IterativeClosestPoint<PointSource, PointTarget, Scalar> {
public:
  /** PCL's ICP this class extends. */
  using Base = pcl::IterativeClosestPoint<PointSource, PointTarget, Scalar>;
  /** Shared pointer, as PCL's. */
  using Ptr = pcl::shared_ptr<ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>>;
  /** Shared pointer to const, as PCL's. */
  using ConstPtr =
      pcl::shared_ptr<const ParallelIterativeClosestPoint<PointSource, PointTarget, Scalar>>;
  /** Source cloud type. */
  using PointCloudSource = typename Base::PointCloudSource;
  /** Target cloud type. */
  using PointCloudTarget = typename Base::PointCloudTarget;
  /** Shared pointer to a const target cloud. */
  using PointCloudTargetConstPtr = typename Base::PointCloudTargetConstPtr;
  /** Transform matrix type. */
  using Matrix4 = typename Base::Matrix4;
  /** Neighbours per estimated target normal unless setNormalEstimationK() says. */
  static constexpr unsigned kDefaultNormalK = 10;
  /** The target tree type (pcl_parallel's k-d tree). */
  using TargetTree = pcl_parallel::search::KdTree<PointTarget>;
  /** The parallel correspondence estimation used by default. */
  using CorrespondenceEstimation =
      ParallelCorrespondenceEstimation<PointSource, PointTarget, Scalar>;
  /** The convergence criteria fed by the fused pass. */
  using ConvergenceCriteria = FusedConvergenceCriteria<Scalar>;

  /** How the fast path computes the rotation from the correlation matrix H (Eq. 9). */
  enum class RotationMethod {
    kSvd,           ///< Arun et al.: R = V Uᵀ from H = U Λ Vᵀ (paper's theorem, default)
    kHornQuaternion ///< Horn: eigenvector of the 4x4 symmetric matrix built from H
  };

  ParallelIterativeClosestPoint();
  ~ParallelIterativeClosestPoint() override = default;

  /** Threads for the fused pass, tree building and our correspondence estimation;
   *  0 (default) = all cores. */
  void
  setNumberOfThreads(unsigned num_threads);
  /** Threads used (0: all cores). */
  unsigned
  getNumberOfThreads() const
  {
    return num_threads_;
  }

  /** Rotation from the moments: Arun's SVD (Eq. 9, default) or Horn's quaternion. */
  void
  setRotationMethod(RotationMethod method)
  {
    rotation_method_ = method;
  }
  /** The rotation method (setRotationMethod). */
  RotationMethod
  getRotationMethod() const
  {
    return rotation_method_;
  }

  /** The paper's 2D special case (Sec. VII, fast path only): every step is a motion in the
   *  x-y plane, x, y and the yaw about z (Eq. 11-13 in 2D; point-to-plane: the planar
   *  block of its normal equations). For scans in that plane (a horizontal 2D scanner's,
   *  z = 0) and a planar guess, whose z, roll and pitch the result then keeps exactly.
   *  Point-to-plane normals it estimates lie in the plane (point-to-line); normal fields
   *  used (setUseTargetNormalFields) must too. */
  void
  setPlanar(bool planar)
  {
    normals_valid_ = normals_valid_ && planar == planar_;
    planar_ = planar;
  }
  /** True when the steps are planar (setPlanar). */
  bool
  getPlanar() const
  {
    return planar_;
  }

  /** Point-to-plane error instead of PCL's point-to-point (fast path only), as
   *  pcl::IterativeClosestPointWithNormals with TransformationEstimationPointToPlaneLLS.
   *  Target normals come from the target's normal_x/y/z fields when PointTarget has them
   *  and setUseTargetNormalFields(true) (default), else they are estimated from the
   *  setNormalEstimationK() nearest target points (PCA, oriented towards the origin). */
  void
  setUsePointToPlane(bool point_to_plane)
  {
    point_to_plane_ = point_to_plane;
  }
  /** True when point-to-plane is on (setUsePointToPlane). */
  bool
  getUsePointToPlane() const
  {
    return point_to_plane_;
  }
  /** Point-to-plane: take the target's normals from its normal_x/y/z fields instead of
   *  estimating them. */
  void
  setUseTargetNormalFields(bool use)
  {
    use_normal_fields_ = use;
    normals_valid_ = false;
  }
  /** True when the target's normal fields are used (setUseTargetNormalFields). */
  bool
  getUseTargetNormalFields() const
  {
    return use_normal_fields_;
  }
  /** Neighbours per estimated normal (default kDefaultNormalK; at least 3). */
  void
  setNormalEstimationK(unsigned k)
  {
    normal_k_ = k < 3 ? 3 : k;
    normals_valid_ = false;
  }
  /** Neighbours per estimated target normal. */
  unsigned
  getNormalEstimationK() const
  {
    return normal_k_;
  }
  /** Target normals of the last point-to-plane align(), 3 floats per target tree position
   *  (empty before). They are reused by the next align() as long as the target is
   *  unchanged: no setInputTarget() in between, or setSearchMethodTarget(tree, true) (the
   *  caller's promise that tree and target are current) before it; a tree with a new
   *  index (setInputCloud, setInputCloudAndIndex) means new normals. */
  const std::vector<float>&
  getTargetNormals() const
  {
    return target_normals_;
  }

  /** IRLS weights on the residuals (fast path only); RobustKernel::Type::kNone (default)
   *  is PCL's unweighted least squares. Throws std::invalid_argument for a kernel whose
   *  scale is not positive and finite. */
  void
  setRobustKernel(const RobustKernel& kernel);
  /** The robust kernel (setRobustKernel). */
  const RobustKernel&
  getRobustKernel() const
  {
    return kernel_;
  }

  /** A Gaussian prior on the pose, the maximum a posteriori extension of point-to-plane
   *  ICP (fast path, point-to-plane only; ignored otherwise): each iteration adds
   *  weight_translation |t_T - t_P|^2 + weight_rotation |log(R_T R_P^T)|^2, linearised in
   *  the step, to the pairs' normal equations, where T is the estimate and P the prior;
   *  t is the sensor origin. The weights are relative to one pair's squared residual:
   *  (s / sigma_t)^2 and (s / sigma_r)^2 for a residual scale s and the prior's standard
   *  deviations. Directions the pairs constrain well barely move; directions they leave
   *  open (a scan of one wall, a few hundred points swung fast) stay at the prior instead
   *  of drifting. 0, 0 (default) is plain ICP. Throws std::invalid_argument for a weight
   *  that is negative or not finite. */
  void
  setMotionPrior(const Eigen::Matrix4d& prior,
                 double weight_translation,
                 double weight_rotation);
  /** Removes the motion prior (setMotionPrior). */
  void
  clearMotionPrior()
  {
    prior_weight_t_ = prior_weight_r_ = 0.0;
  }

  /** align() with a double-precision guess: on the fast path the estimate is composed in
   *  double (getFinalTransformationDouble()), so poses far from the origin keep their
   *  precision; getFinalTransformation() is its Scalar rounding. On PCL's loop the guess is
   *  rounded to Scalar. */
  void
  alignDouble(PointCloudSource& output, const Eigen::Matrix4d& guess);
  /** The final transform in double: composed in double after alignDouble(), the Scalar
   *  result widened after align(). */
  const Eigen::Matrix4d&
  getFinalTransformationDouble() const
  {
    return final_transformation_double_;
  }

  /** Point-to-plane on the fast path: the Gauss-Newton Hessian Σ w Jᵀ J of the last
   *  iteration's pairs (robust weights, no motion prior) for a perturbation T Exp(ε) of
   *  the final transform T in the source frame, ε = (ω, t) rotation first, as small_gicp's
   *  RegistrationResult::H; getFinalError() / getFinalWeight() (Σ w r² / Σ w) estimates
   *  the residual variance, and H over it the match's information (inverse covariance).
   *  Zero after any other align(). */
  const Eigen::Matrix<double, 6, 6>&
  getFinalHessian() const
  {
    return final_hessian_;
  }
  /** The last iteration's weighted sum of squared residuals (point-to-plane). */
  double
  getFinalError() const
  {
    return final_error_;
  }
  /** The last iteration's sum of weights (point-to-plane). */
  double
  getFinalWeight() const
  {
    return final_weight_;
  }

  /** Drops the private target tree, then PCL's setInputTarget. */
  void
  setInputTarget(const PointCloudTargetConstPtr& cloud) override;

  /** Mean squared distance of the transformed source points to their closest target
   *  point, over those within \a max_range (squared distance, as PCL), computed in
   *  parallel on our tree. Hides the non-virtual Registration::getFitnessScore. */
  double
  getFitnessScore(double max_range = std::numeric_limits<double>::max());

  /** Whether the last align() took the fused fast path (false: PCL's loop). */
  bool
  usedFastPath() const
  {
    return used_fast_path_;
  }

protected:
  using Base::converged_;
  using Base::corr_dist_threshold_;
  using Base::correspondence_estimation_;
  using Base::correspondence_rejectors_;
  using Base::correspondences_;
  using Base::euclidean_fitness_epsilon_;
  using Base::final_transformation_;
  using Base::getClassName;
  using Base::input_;
  using Base::max_iterations_;
  using Base::min_number_correspondences_;
  using Base::nr_iterations_;
  using Base::previous_transformation_;
  using Base::reg_name_;
  using Base::target_;
  using Base::transformation_;
  using Base::transformation_epsilon_;
  using Base::transformation_estimation_;
  using Base::transformation_rotation_epsilon_;
  using Base::update_visualizer_;
  using Base::use_reciprocal_correspondence_;
  using pcl::Registration<PointSource, PointTarget, Scalar>::tree_;
  using pcl::Registration<PointSource, PointTarget, Scalar>::force_no_recompute_;
  using pcl::Registration<PointSource, PointTarget, Scalar>::target_cloud_updated_;

  /** PCL's entry point from align(): the fused parallel pass when every component is the
   *  default, else PCL's loop. */
  void
  computeTransformation(PointCloudSource& output, const Matrix4& guess) override;

  /** True when every component is PCL's default, i.e. the fused pass computes exactly
   *  what PCL's loop would. */
  bool
  fastPathApplies() const;

  /** The fused loop (Eq. 2-13). */
  void
  computeTransformationFused(PointCloudSource& output, const Matrix4& guess);

  /** PCL's convergence criteria set from this object's limits, as computeTransformation. */
  void
  setUpCriteria(ConvergenceCriteria& criteria) const;

  /** The estimate moved by one step (composed in double after alignDouble, in Scalar as
   *  PCL otherwise), and the iteration counted. */
  void
  applyStep(const Eigen::Matrix4d& step);

  /** One pass over the source: the step for the current estimate \a tr, the pairs' count
   *  and MSE. False when the step cannot be solved (point-to-plane: singular system). */
  bool
  fusedStep(const KdTreeIndex& target,
            const SearchTransform& tr,
            Eigen::Matrix4d& step,
            double& pairs,
            double& mse);

  /** fusedStep()'s pass for point-to-point pairs: their moments (Eq. 12-13). */
  PointToPointMoments
  pointToPointPass(const KdTreeIndex& target,
                   const SearchTransform& tr,
                   float bound,
                   std::vector<NearestSlot>& slots);

  /** fusedStep()'s pass for point-to-plane pairs: their normal equations in coordinates
   *  shifted by the target point `ref`. */
  NormalEquations
  pointToPlanePass(const KdTreeIndex& target,
                   const SearchTransform& tr,
                   float bound,
                   const double ref[3],
                   std::vector<NearestSlot>& slots);

  /** The point-to-plane step from the pairs' normal equations, with the motion prior if
   *  one is set; keeps the pairs' own information (final_hessian_). */
  bool
  solvePointToPlane(const NormalEquations& total, const double ref[3], Eigen::Matrix4d& step);

  /** Target normals per tree position (fields or estimated), reused while valid. */
  void
  updateTargetNormals(const KdTreeIndex& target);

  /** The index the target is searched with: tree_'s if it is ours (built here if the
   *  target changed and force_no_recompute is off), else a private one. Null on error. */
  const KdTreeIndex*
  targetIndex();

private:
  unsigned num_threads_ = 0;
  RotationMethod rotation_method_ = RotationMethod::kSvd;
  bool used_fast_path_ = false;
  typename TargetTree::Ptr private_tree_; ///< when tree_ is not a pcl_parallel tree
  std::vector<std::uint32_t> order_;      ///< source points in spatial (Morton) order
  std::vector<std::uint32_t> warm_;       ///< per order_ entry: last match (tree position)
  std::vector<std::vector<MatchedPair>> pair_buffers_; ///< one per thread: a block's pairs
  bool point_to_plane_ = false;
  bool planar_ = false;
  bool use_normal_fields_ = true;
  unsigned normal_k_ = kDefaultNormalK;
  RobustKernel kernel_;
  std::vector<float> target_normals_; ///< 3 per target tree position
  bool normals_valid_ = false;
  std::shared_ptr<const KdTreeIndex> target_index_;  ///< targetIndex()'s, held
  std::shared_ptr<const KdTreeIndex> normals_index_; ///< the tree target_normals_ belong to
  bool use_double_ = false;                          ///< alignDouble() in progress
  Eigen::Matrix4d guess_double_ = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d final_transformation_double_ = Eigen::Matrix4d::Identity();
  Eigen::Matrix4d prior_ = Eigen::Matrix4d::Identity();
  double prior_weight_t_ = 0.0, prior_weight_r_ = 0.0;
  Eigen::Matrix<double, 6, 6> final_hessian_ = Eigen::Matrix<double, 6, 6>::Zero();
  double final_error_ = 0.0, final_weight_ = 0.0;
};

namespace detail {
/** Indices of the finite points among \a n (stride floats apart) sorted by the Morton
 *  (Z-order) code of their position in a 2^21 grid over their bounding box, ties by
 *  index. Visiting queries in this order makes consecutive searches walk the same part
 *  of the target tree, so it stays in cache (large clouds in arbitrary order otherwise
 *  miss on almost every node). The order is a function of the input alone. */
void
spatialOrder(const float* xyz,
             std::size_t n,
             std::size_t stride,
             std::vector<std::uint32_t>& order);

} // namespace detail

} // namespace registration

// The mission's short names: pcl_parallel::ParallelIterativeClosestPoint and friends.
using registration::ParallelCorrespondenceEstimation;
using registration::ParallelIterativeClosestPoint;

} // namespace pcl_parallel

#ifdef PCL_NO_PRECOMPILE
#include <pcl_parallel/registration/impl/icp.hpp>
#endif
