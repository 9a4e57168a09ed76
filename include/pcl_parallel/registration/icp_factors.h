/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace pcl_parallel {
namespace registration {

/**
 * \brief Robust kernel as IRLS weights w(r) = ρ'(r) / r, normalised to w(0) = 1
 * (Zhang, "Parameter estimation techniques: a tutorial", IVC 1997, Table 1).
 * Huber: w = 1 for |r| <= s, s / |r| beyond. Geman-McClure: w = (s² / (s² + r²))²
 * (KISS-ICP uses the same weight with its kernel value in place of s²).
 */
struct RobustKernel {
  /** The kernels: none (least squares), Huber, Geman-McClure. */
  enum class Type { kNone, kHuber, kGemanMcClure };
  /** Which kernel. */
  Type type = Type::kNone;
  double scale = 1.0; ///< s, in the units of the residual (point distance or plane distance)

  /** Weight of a residual given as r². */
  double
  weight(double sqr_residual) const
  {
    switch (type) {
    case Type::kHuber: {
      const double r = std::sqrt(sqr_residual);
      return r <= scale ? 1.0 : scale / r;
    }
    case Type::kGemanMcClure: {
      const double f = scale * scale / (scale * scale + sqr_residual);
      return f * f;
    }
    default:
      return 1.0;
    }
  }
};

/** One pair of the fused pass: transformed source point d, its match m in the target
 *  tree, and the pair's IRLS weight. */
struct MatchedPair {
  /** The transformed source point d. */
  float d[3];
  /** Its match m in the target tree (x, y, z). */
  const float* m;
  /** The pair's IRLS weight. */
  double w;
};

/**
 * \brief Moments of one child (block) of point pairs, paper Eq. 11-13, with weights.
 * cd, cm are the child's (weighted) centroids and h = H_i of Eq. 13, written with d
 * first as Arun's method uses it: H_i = Σ w (d - cd)(m - cm)ᵀ, the transpose of the
 * paper's Σ (m - cm)(d - cd)ᵀ.
 */
struct PointToPointMoments {
  double n = 0.0;        ///< pairs
  double w = 0.0;        ///< Σ w (= n without a robust kernel)
  double sqr_dist = 0.0; ///< Σ |m - d|² (the correspondences' `distance` in PCL)
  /** Weighted centroid of the source points, c_di. */
  double cd[3] = {0, 0, 0};
  /** Weighted centroid of the target points, c_mi. */
  double cm[3] = {0, 0, 0};
  double h[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0}; ///< row-major
};

/** Point-to-point error (paper Eq. 2): closed form from the pairs' moments. */
struct PointToPointFactor {
  /** Eq. 13 for one child, as written: centroids first, then H_i about them (two passes
   *  over the block's buffered pairs). \a sqr_dist is the pairs' Σ |m - d|². */
  static PointToPointMoments
  child(const MatchedPair* pairs, std::size_t count, double sqr_dist);

  /** Eq. 12: H = Σ_i H_i + W_i (cd_i - cd)(cm_i - cm)ᵀ over the children, with the global
   *  centroids cd, cm the weighted means of the children's. */
  static PointToPointMoments
  combine(const std::vector<PointToPointMoments>& children);

  /** Rotation from H (Eq. 9: Arun's SVD with the reflection case handled, or \a horn:
   *  Horn's unit quaternion), translation t = cm - R cd (Eq. 7). */
  static Eigen::Matrix4d
  solve(const PointToPointMoments& total, bool horn);

  /** The planar special case (Sec. VII): the yaw maximising Σ w (m - cm)ᵀ R_z (d - cd),
   *  θ = atan2(H_xy - H_yx, H_xx + H_yy), and t = cm - R cd in x and y alone. */
  static Eigen::Matrix4d
  solvePlanar(const PointToPointMoments& total);
};

/**
 * \brief Gauss-Newton normal equations of the point-to-plane error Σ w ((R d + t - m)·n)²
 * linearised at the identity (R ≈ I + [ω]x), in coordinates shifted by a fixed reference
 * point: residual r = (d - m)·n, Jacobian J = [d × n, n] (as PCL's
 * TransformationEstimationPointToPlaneLLS). Summed per fixed block, added in block order.
 */
struct NormalEquations {
  /** Pairs summed. */
  double n = 0.0;
  /** Sum of weights. */
  double w = 0.0;
  double sqr_dist = 0.0;    ///< Σ |m - d|² (PCL's MSE, as for point-to-point)
  double sd[3] = {0, 0, 0}; ///< Σ w d: the rotation is applied about the weighted centroid
  double jtj[21] = {};      ///< upper triangle of Σ w Jᵀ J, row by row
  double jtr[6] = {0, 0, 0, 0, 0, 0}; ///< Σ w Jᵀ r
  double rtr = 0.0;                   ///< Σ w r²

  /** Adds one pair (d, m shifted by the reference; nrm the target normal). */
  void
  add(const double d[3], const double m[3], const float nrm[3], const RobustKernel& kernel)
  {
    const double r = (d[0] - m[0]) * nrm[0] + (d[1] - m[1]) * nrm[1] + (d[2] - m[2]) * nrm[2];
    const double wt = kernel.weight(r * r);
    const double j[6] = {d[1] * nrm[2] - d[2] * nrm[1],
                         d[2] * nrm[0] - d[0] * nrm[2],
                         d[0] * nrm[1] - d[1] * nrm[0],
                         nrm[0],
                         nrm[1],
                         nrm[2]};
    w += wt;
    rtr += wt * r * r;
    int k = 0;
    for (int a = 0; a < 6; ++a) {
      const double wj = wt * j[a];
      jtr[a] += wj * r;
      for (int b = a; b < 6; ++b)
        jtj[k++] += wj * j[b];
    }
    for (int a = 0; a < 3; ++a)
      sd[a] += wt * d[a];
  }

  /** Adds another block's sums (blocks are added in block order). */
  void
  operator+=(const NormalEquations& o)
  {
    n += o.n;
    w += o.w;
    sqr_dist += o.sqr_dist;
    for (int a = 0; a < 3; ++a)
      sd[a] += o.sd[a];
    for (int k = 0; k < 21; ++k)
      jtj[k] += o.jtj[k];
    for (int a = 0; a < 6; ++a)
      jtr[a] += o.jtr[a];
    rtr += o.rtr;
  }

  /** Σ w Jᵀ J as a full symmetric matrix. */
  Eigen::Matrix<double, 6, 6>
  hessian() const;
};

/** Point-to-plane error (Chen and Medioni 1992; PCL's IterativeClosestPointWithNormals). */
struct PointToPlaneFactor {
  /** Solves the 6x6 system for (ω, t) and returns the rigid step in unshifted
   *  coordinates: R = Rz(ω_z) Ry(ω_y) Rx(ω_x) (PCL's constructTransformationMatrix) applied
   *  about the pairs' weighted centroid, which is the same first-order motion as about the
   *  reference. False when the system is singular (e.g. all normals parallel). */
  static bool
  solve(const NormalEquations& eq, const double ref[3], Eigen::Matrix4d& step);

  /** The same restricted to the planar parameters (ω_z, t_x, t_y): the 3x3 block of the
   *  normal equations, the other three held at zero. */
  static bool
  solvePlanar(const NormalEquations& eq, const double ref[3], Eigen::Matrix4d& step);

  /** eq's Σ w Jᵀ J for a perturbation T Exp(ε) of the estimate T in the source (body)
   *  frame, ε = (ω, t) rotation first (small_gicp's RegistrationResult::H): the
   *  information of the match, up to the residual variance, in the sensor's frame. */
  static Eigen::Matrix<double, 6, 6>
  bodyHessian(const NormalEquations& eq, const double ref[3], const Eigen::Matrix4d& estimate);

  /** Adds a Gaussian prior on the pose to eq (ParallelIterativeClosestPoint::
   *  setMotionPrior): residual e + A x with e = (rotation vector of R_T R_P^T, t_T - t_P)
   *  and A the first-order effect of the step x = (ω, t) on it (the sensor origin moves
   *  by ω × (t_T - ref) + t), weighted by w_r, w_t: H += Aᵀ W A, g += Aᵀ W e. */
  static void
  addPosePrior(NormalEquations& eq,
               const double ref[3],
               const Eigen::Matrix4d& estimate,
               const Eigen::Matrix4d& prior,
               double weight_translation,
               double weight_rotation);
};

} // namespace registration
} // namespace pcl_parallel
