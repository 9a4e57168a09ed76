/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/registration/icp_factors.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/QR>
#include <Eigen/SVD>

#include <cmath>

namespace pcl_parallel {
namespace registration {

PointToPointMoments
PointToPointFactor::child(const MatchedPair* pairs, std::size_t count, double sqr_dist)
{
  PointToPointMoments c;
  c.n = static_cast<double>(count);
  c.sqr_dist = sqr_dist;
  double sd[3] = {0, 0, 0}, sm[3] = {0, 0, 0};
  for (std::size_t k = 0; k < count; ++k) {
    const MatchedPair& p = pairs[k];
    c.w += p.w;
    for (int a = 0; a < 3; ++a) {
      sd[a] += p.w * p.d[a];
      sm[a] += p.w * p.m[a];
    }
  }
  if (!(c.w > 0.0))
    return c;
  // Centroids c_di, c_mi of the child (Eq. 13's), then H_i about them.
  for (int a = 0; a < 3; ++a) {
    c.cd[a] = sd[a] / c.w;
    c.cm[a] = sm[a] / c.w;
  }
  for (std::size_t k = 0; k < count; ++k) {
    const MatchedPair& p = pairs[k];
    const double dd[3] = {p.d[0] - c.cd[0], p.d[1] - c.cd[1], p.d[2] - c.cd[2]};
    const double mm[3] = {p.m[0] - c.cm[0], p.m[1] - c.cm[1], p.m[2] - c.cm[2]};
    for (int a = 0; a < 3; ++a) {
      const double wd = p.w * dd[a];
      for (int b = 0; b < 3; ++b)
        c.h[3 * a + b] += wd * mm[b];
    }
  }
  return c;
}

PointToPointMoments
PointToPointFactor::combine(const std::vector<PointToPointMoments>& children)
{
  PointToPointMoments t;
  double sd[3] = {0, 0, 0}, sm[3] = {0, 0, 0};
  for (const PointToPointMoments& c : children) {
    t.n += c.n;
    t.w += c.w;
    t.sqr_dist += c.sqr_dist;
    for (int a = 0; a < 3; ++a) {
      sd[a] += c.w * c.cd[a];
      sm[a] += c.w * c.cm[a];
    }
  }
  if (!(t.w > 0.0))
    return t;
  for (int a = 0; a < 3; ++a) {
    t.cd[a] = sd[a] / t.w;
    t.cm[a] = sm[a] / t.w;
  }
  // Eq. 12: each child's H_i plus its centroids' offset from the global ones.
  for (const PointToPointMoments& c : children) {
    if (!(c.w > 0.0))
      continue;
    const double od[3] = {c.cd[0] - t.cd[0], c.cd[1] - t.cd[1], c.cd[2] - t.cd[2]};
    const double om[3] = {c.cm[0] - t.cm[0], c.cm[1] - t.cm[1], c.cm[2] - t.cm[2]};
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        t.h[3 * a + b] += c.h[3 * a + b] + c.w * od[a] * om[b];
  }
  return t;
}

Eigen::Matrix4d
PointToPointFactor::solve(const PointToPointMoments& mo, bool horn)
{
  const Eigen::Matrix3d H =
      Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(mo.h);
  Eigen::Matrix3d R;
  if (!horn) {
    // Arun et al.: H = U Λ Vᵀ, R = V Uᵀ; a reflection (det < 0) flips V's last column.
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const Eigen::Matrix3d& u = svd.matrixU();
    Eigen::Matrix3d v = svd.matrixV();
    if (u.determinant() * v.determinant() < 0)
      v.col(2) *= -1.0;
    R = v * u.transpose();
  }
  else {
    // Horn (1987): the unit quaternion maximising Σ m'·(R d') is the eigenvector of the
    // largest eigenvalue of N built from S = H (S_ab = Σ d'_a m'_b).
    const Eigen::Matrix3d& S = H;
    Eigen::Matrix4d N;
    N << S(0, 0) + S(1, 1) + S(2, 2), S(1, 2) - S(2, 1), S(2, 0) - S(0, 2), S(0, 1) - S(1, 0),
        S(1, 2) - S(2, 1), S(0, 0) - S(1, 1) - S(2, 2), S(0, 1) + S(1, 0), S(2, 0) + S(0, 2),
        S(2, 0) - S(0, 2), S(0, 1) + S(1, 0), -S(0, 0) + S(1, 1) - S(2, 2), S(1, 2) + S(2, 1),
        S(0, 1) - S(1, 0), S(2, 0) + S(0, 2), S(1, 2) + S(2, 1), -S(0, 0) - S(1, 1) + S(2, 2);
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix4d> eig(N);
    const Eigen::Vector4d q = eig.eigenvectors().col(3); // eigenvalues ascending
    R = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  }
  // t = cm - R cd (Eq. 7).
  const Eigen::Vector3d cd(mo.cd[0], mo.cd[1], mo.cd[2]);
  const Eigen::Vector3d cm(mo.cm[0], mo.cm[1], mo.cm[2]);
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = R;
  T.topRightCorner<3, 1>() = cm - R * cd;
  return T;
}

Eigen::Matrix4d
PointToPointFactor::solvePlanar(const PointToPointMoments& mo)
{
  // H_ab = Σ w d'_a m'_b: tr(R_z H) = cos θ (H_xx + H_yy) + sin θ (H_xy - H_yx).
  const double theta = std::atan2(mo.h[1] - mo.h[3], mo.h[0] + mo.h[4]);
  const double c = std::cos(theta), s = std::sin(theta);
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T(0, 0) = c;
  T(0, 1) = -s;
  T(1, 0) = s;
  T(1, 1) = c;
  T(0, 3) = mo.cm[0] - (c * mo.cd[0] - s * mo.cd[1]); // t = cm - R cd in the plane (Eq. 7)
  T(1, 3) = mo.cm[1] - (s * mo.cd[0] + c * mo.cd[1]);
  return T;
}

Eigen::Matrix<double, 6, 6>
NormalEquations::hessian() const
{
  Eigen::Matrix<double, 6, 6> h;
  int k = 0;
  for (int a = 0; a < 6; ++a)
    for (int b = a; b < 6; ++b)
      h(a, b) = h(b, a) = jtj[k++];
  return h;
}

Eigen::Matrix<double, 6, 6>
PointToPlaneFactor::bodyHessian(const NormalEquations& eq,
                                const double ref[3],
                                const Eigen::Matrix4d& estimate)
{
  // The step x = (ω, t) moves a target-frame point d to d + ω × (d - ref) + t. The body
  // perturbation T Exp(ε), ε = (ω_b, t_b), moves T p to T p + R ω_b × (T p - t_T) + R t_b:
  // ω = R ω_b, t = R t_b + ω × (ref - t_T). x = K ε, and Σ JᵀJ becomes Kᵀ (Σ JᵀJ) K.
  const Eigen::Matrix3d R = estimate.topLeftCorner<3, 3>();
  const Eigen::Vector3d lever =
      Eigen::Vector3d(ref[0], ref[1], ref[2]) - estimate.topRightCorner<3, 1>();
  Eigen::Matrix<double, 6, 6> K = Eigen::Matrix<double, 6, 6>::Zero();
  K.topLeftCorner<3, 3>() = R;
  K.bottomLeftCorner<3, 3>() = -skew(lever) * R;
  K.bottomRightCorner<3, 3>() = R;
  return K.transpose() * eq.hessian() * K;
}

namespace {

/** x solving the Gauss-Newton system (Σ Jᵀ J) x = -Σ Jᵀ r, or false where it is rank
 *  deficient (fewer independent constraints than unknowns: no unique step, not a wild one). */
template <int N>
bool
gaussNewtonStep(const Eigen::Matrix<double, N, N>& A,
                const Eigen::Matrix<double, N, 1>& g,
                Eigen::Matrix<double, N, 1>& x)
{
  Eigen::FullPivLU<Eigen::Matrix<double, N, N>> lu(A);
  lu.setThreshold(1e-12);
  if (lu.rank() < N)
    return false;
  x = lu.solve(-g);
  return x.allFinite();
}

/** The rigid step of the linearised motion (ω, t) in unshifted coordinates. */
Eigen::Matrix4d
stepAboutCentroid(const NormalEquations& eq,
                  const double ref[3],
                  const Eigen::Vector3d& omega,
                  const Eigen::Vector3d& t)
{
  // Same linear motion ω × d + t about the weighted centroid c: t_c = t + ω × c.
  const Eigen::Vector3d c = Eigen::Vector3d(eq.sd[0], eq.sd[1], eq.sd[2]) / eq.w;
  const Eigen::Vector3d t_c = t + omega.cross(c);
  const Eigen::Matrix3d R = eulerZYXToRotation(omega[0], omega[1], omega[2]);
  // d -> R (d - r - c) + r + c + t_c in unshifted coordinates.
  const Eigen::Vector3d rc = Eigen::Vector3d(ref[0], ref[1], ref[2]) + c;
  Eigen::Matrix4d step = Eigen::Matrix4d::Identity();
  step.topLeftCorner<3, 3>() = R;
  step.topRightCorner<3, 1>() = rc + t_c - R * rc;
  return step;
}

} // namespace

bool
PointToPlaneFactor::solve(const NormalEquations& eq, const double ref[3], Eigen::Matrix4d& step)
{
  Eigen::Matrix<double, 6, 1> x;
  if (!(eq.w > 0.0) ||
      !gaussNewtonStep<6>(
          eq.hessian(), Eigen::Map<const Eigen::Matrix<double, 6, 1>>(eq.jtr), x))
    return false;
  step = stepAboutCentroid(eq, ref, x.head<3>(), x.tail<3>());
  return true;
}

bool
PointToPlaneFactor::solvePlanar(const NormalEquations& eq,
                                const double ref[3],
                                Eigen::Matrix4d& step)
{
  constexpr int kPlanar[3] = {2, 3, 4}; // ω_z, t_x, t_y of (ω, t)
  const Eigen::Matrix<double, 6, 6> full = eq.hessian();
  Eigen::Matrix3d A;
  Eigen::Vector3d g, x;
  for (int a = 0; a < 3; ++a) {
    g[a] = eq.jtr[kPlanar[a]];
    for (int b = 0; b < 3; ++b)
      A(a, b) = full(kPlanar[a], kPlanar[b]);
  }
  if (!(eq.w > 0.0) || !gaussNewtonStep<3>(A, g, x))
    return false;
  step = stepAboutCentroid(
      eq, ref, Eigen::Vector3d(0.0, 0.0, x[0]), Eigen::Vector3d(x[1], x[2], 0.0));
  return true;
}

void
PointToPlaneFactor::addPosePrior(NormalEquations& eq,
                                 const double ref[3],
                                 const Eigen::Matrix4d& estimate,
                                 const Eigen::Matrix4d& prior,
                                 double weight_translation,
                                 double weight_rotation)
{
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() =
      so3Log(estimate.topLeftCorner<3, 3>() * prior.topLeftCorner<3, 3>().transpose());
  e.tail<3>() = estimate.topRightCorner<3, 1>() - prior.topRightCorner<3, 1>();
  // The step moves the sensor origin s (shifted by ref) by ω × s + t.
  const Eigen::Vector3d s =
      estimate.topRightCorner<3, 1>() - Eigen::Vector3d(ref[0], ref[1], ref[2]);
  Eigen::Matrix<double, 6, 6> a = Eigen::Matrix<double, 6, 6>::Identity();
  a.bottomLeftCorner<3, 3>() = -skew(s);
  Eigen::Matrix<double, 6, 1> w;
  w << Eigen::Vector3d::Constant(weight_rotation),
      Eigen::Vector3d::Constant(weight_translation);
  const Eigen::Matrix<double, 6, 6> h = a.transpose() * w.asDiagonal() * a;
  const Eigen::Matrix<double, 6, 1> g = a.transpose() * w.asDiagonal() * e;
  int k = 0;
  for (int r = 0; r < 6; ++r) {
    eq.jtr[r] += g(r);
    for (int c = r; c < 6; ++c)
      eq.jtj[k++] += h(r, c);
  }
}

} // namespace registration
} // namespace pcl_parallel
