/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/evaluation/pose_error.h>
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/normal_estimation.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/registration/lum_solver.h>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <cmath>
#include <numeric>

namespace pcl_parallel {
namespace lum {

Eigen::Matrix4d
poseToMatrix(const Eigen::Matrix<float, 6, 1>& pose)
{
  const Eigen::Matrix<double, 6, 1> p = pose.cast<double>();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(p(5), Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(p(4), Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(p(3), Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  m.topRightCorner<3, 1>() = p.head<3>();
  return m;
}

Eigen::Matrix<float, 6, 1>
matrixToPose(const Eigen::Matrix4d& m)
{
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  Eigen::Matrix<float, 6, 1> out;
  out.head<3>() = m.topRightCorner<3, 1>().cast<float>();
  // R = Rz(yaw) Ry(pitch) Rx(roll): R(2,0) = -sin(pitch). atan2 instead of PCL's asin
  // keeps pitch accurate near +-90 deg.
  const double cp = std::hypot(r(0, 0), r(1, 0));
  const double pitch = std::atan2(-r(2, 0), cp);
  double roll, yaw;
  if (cp > 1e-9) {
    roll = std::atan2(r(2, 1), r(2, 2));
    yaw = std::atan2(r(1, 0), r(0, 0));
  }
  else { // gimbal lock: only yaw -+ roll is defined; put it all into yaw
    roll = 0.0;
    yaw = std::atan2(-r(0, 1), r(1, 1));
  }
  out(3) = static_cast<float>(roll);
  out(4) = static_cast<float>(pitch);
  out(5) = static_cast<float>(yaw);
  return out;
}

void
applyUpdate(Eigen::Matrix4d& pose, const Vector6d& delta)
{
  const Eigen::Vector3d t = delta.head<3>();
  const Eigen::Vector3d w = delta.tail<3>();
  const Eigen::Vector3d c = pose.topRightCorner<3, 1>();
  const double angle = w.norm();
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  if (angle > 0.0)
    r = Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  // p -> r (p - c) + c + t + w x c, i.e. p + w x p + t to first order.
  Eigen::Matrix4d d = Eigen::Matrix4d::Identity();
  d.topLeftCorner<3, 3>() = r;
  d.topRightCorner<3, 1>() = c - r * c + t + w.cross(c);
  pose = orthonormalized(d * pose); // over many updates
}

Eigen::Matrix4d
orthonormalized(const Eigen::Matrix4d& pose)
{
  Eigen::Matrix4d out = pose;
  out.topLeftCorner<3, 3>() = Eigen::Quaterniond(Eigen::Matrix3d(pose.topLeftCorner<3, 3>()))
                                  .normalized()
                                  .toRotationMatrix();
  return out;
}

void
poseError(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b, double& angle, double& dist)
{
  const evaluation::PoseError e = evaluation::poseError(a, b);
  angle = e.angle;
  dist = e.distance;
}

bool
LinkAccumulator::solveCentred(
    std::size_t min_pairs, Matrix6d& a, Vector6d& c, Vector6d& d_bar, const char** reason) const
{
  auto fail = [&](const char* why) {
    if (reason)
      *reason = why;
    return false;
  };
  if (n_ < std::max<std::size_t>(min_pairs, 3))
    return fail("too few point pairs");

  // A' and c' in the frame centred at origin_ (M' = [I, -[m']x]).
  a = sum_w_;
  a.bottomLeftCorner<3, 3>() = sum_w_.topRightCorner<3, 3>().transpose();
  a.topLeftCorner<3, 3>().diagonal().array() += static_cast<double>(n_identity_);
  a.topRightCorner<3, 3>() -= skew(sum_m_);
  a.bottomLeftCorner<3, 3>() += skew(sum_m_);
  a.bottomRightCorner<3, 3>() += sum_mmt_.trace() * Eigen::Matrix3d::Identity() - sum_mmt_;
  c = sum_wc_;
  c.head<3>() += sum_r_;
  c.tail<3>() += sum_mxr_;

  // Singular A: the pairs do not fix all six DoF (e.g. collinear points). Judged on the
  // unit-diagonal scaling, so units and point spread do not matter.
  const Vector6d scale = a.diagonal().cwiseSqrt().cwiseInverse();
  if (!scale.allFinite())
    return fail("degenerate point pairs");
  const Matrix6d a_scaled = scale.asDiagonal() * a * scale.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Matrix6d> eig(a_scaled, Eigen::EigenvaluesOnly);
  if (eig.info() != Eigen::Success || !(eig.eigenvalues()(0) > 1e-9))
    return fail("singular covariance (the pairs do not constrain all six DoF)");
  d_bar = -Eigen::LDLT<Matrix6d>(a).solve(c);
  if (!d_bar.allFinite())
    return fail("non-finite measurement");
  return true;
}

bool
LinkAccumulator::measurement(std::size_t min_pairs, Vector6d& d_bar, const char** reason) const
{
  Matrix6d a;
  Vector6d c;
  if (!solveCentred(min_pairs, a, c, d_bar, reason))
    return false;
  // Centred D' = T D (see finish()), so D = (t' + o x w', w').
  d_bar.head<3>() += origin_.cross(Vector6d(d_bar).tail<3>());
  return true;
}

bool
LinkAccumulator::finish(std::size_t min_pairs,
                        double min_variance,
                        Matrix6d& info,
                        Vector6d& grad,
                        double* variance,
                        const char** reason) const
{
  info.setZero();
  grad.setZero();
  Matrix6d a;
  Vector6d c, d_bar;
  if (!solveCentred(min_pairs, a, c, d_bar, reason))
    return false;

  // Residual after the fit: sum r^T W r at D = -A^-1 c is sum r^T W r - c^T A^-1 c; its
  // expectation for isotropic noise s^2 is s^2 (sum tr W - 6).
  const double ssr = std::max(0.0, sum_rr_ + c.dot(d_bar));
  const double dof = 3.0 * static_cast<double>(n_identity_) + trace_w_ - 6.0;
  const double s2 = std::max(ssr / std::max(dof, 1.0), min_variance);

  // Back to world coordinates: M = M' T with T = [[I, -[o]x], [0, I]].
  Matrix6d t = Matrix6d::Identity();
  t.topRightCorner<3, 3>() = -skew(origin_);
  info = t.transpose() * a * t / s2;
  grad = t.transpose() * c / s2;
  if (variance)
    *variance = s2;
  if (!std::isfinite(s2) || !info.allFinite() || !grad.allFinite()) {
    info.setZero();
    grad.setZero();
    if (reason)
      *reason = "non-finite measurement";
    return false;
  }
  return true;
}

Vector6d
updateBetween(const Eigen::Matrix4d& before, const Eigen::Matrix4d& after)
{
  // after = D before with D = [r, c - r c + t + w x c] (applyUpdate), c = before's position.
  const Eigen::Matrix4d d = after * before.inverse();
  const Eigen::Matrix3d r = d.topLeftCorner<3, 3>();
  const Eigen::AngleAxisd aa(r);
  const Eigen::Vector3d w = aa.angle() * aa.axis();
  const Eigen::Vector3d c = before.topRightCorner<3, 1>();
  Vector6d delta;
  delta.head<3>() = d.topRightCorner<3, 1>() - c + r * c - w.cross(c);
  delta.tail<3>() = w;
  return delta;
}

namespace {

/** (t, rotation vector) of measured^-1 target^-1 source. */
Vector6d
constraintError(const PoseConstraint& c,
                const Eigen::Matrix4d& source_pose,
                const Eigen::Matrix4d& target_pose)
{
  const Eigen::Matrix4d e = c.measured.inverse() * target_pose.inverse() * source_pose;
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(e.topLeftCorner<3, 3>()));
  Vector6d e0;
  e0.head<3>() = e.topRightCorner<3, 1>();
  e0.tail<3>() = aa.angle() * aa.axis();
  return e0;
}

} // namespace

double
constraintChi2(const PoseConstraint& c,
               const Eigen::Matrix4d& source_pose,
               const Eigen::Matrix4d& target_pose)
{
  const Vector6d e0 = constraintError(c, source_pose, target_pose);
  return e0.dot(c.information * e0);
}

LinkBlock
constraintBlock(const PoseConstraint& c,
                const Eigen::Matrix4d& source_pose,
                const Eigen::Matrix4d& target_pose,
                const LinkBlock* link)
{
  LinkBlock b;
  b.source = c.source;
  b.target = c.target;
  const Vector6d e0 = constraintError(c, source_pose, target_pose);
  // Body perturbation of the source by the world update D = (t, w) (applyUpdate's model
  // p -> p + w x p + t): rotation R^T w, translation R^T (t + w x c), c its position.
  const Eigen::Matrix3d rt = source_pose.topLeftCorner<3, 3>().transpose();
  Matrix6d j = Matrix6d::Zero();
  j.topLeftCorner<3, 3>() = rt;
  j.topRightCorner<3, 3>() = -rt * skew(source_pose.topRightCorner<3, 1>());
  j.bottomRightCorner<3, 3>() = rt;
  // Cauchy IRLS weight (Black and Rangarajan 1996) from the current error, judged by the
  // scans' link where there is one: the update the constraint asks for in its information.
  double weight = 1.0;
  if (c.cauchy_scale > 0.0) {
    double chi2 = e0.dot(c.information * e0);
    if (link && link->valid) {
      const Vector6d d = j.partialPivLu().solve(e0); // J is invertible (block triangular)
      chi2 = d.dot(link->info * d);
    }
    weight = 1.0 / (1.0 + chi2 / c.cauchy_scale);
  }
  b.info = weight * (j.transpose() * c.information * j);
  b.grad = weight * (j.transpose() * (c.information * e0));
  b.valid = b.info.allFinite() && b.grad.allFinite();
  return b;
}

std::vector<Eigen::Vector3f>
estimateNormals(const KdTreeIndex& tree, std::size_t k, unsigned num_threads)
{
  const std::size_t n = tree.size();
  std::vector<Eigen::Vector3f> normals(n, Eigen::Vector3f::Zero());
  k = std::max<std::size_t>(k, 3);
  const unsigned threads = resolveNumberOfThreads(num_threads);
  // A scan's few thousand points over every thread.
  parallelFor(n, threads, 256, [&](std::size_t first, std::size_t last) {
    std::vector<std::uint32_t> pos(k);
    std::vector<float> sqr(k);
    for (std::size_t i = first; i < last; ++i) {
      const std::uint32_t p = static_cast<std::uint32_t>(i);
      const std::size_t got = tree.knn(tree.point(p), k, pos.data(), sqr.data());
      Eigen::Vector3d normal, ev;
      // A plane needs two clearly non-zero spreads; the normal's must be the smallest.
      if (!neighbourhoodNormal(tree, pos.data(), got, tree.point(p), normal, ev) ||
          !(ev(1) > 1e-6 * ev(2)))
        continue;
      normals[i] = normal.normalized().cast<float>();
    }
  });
  return normals;
}

struct PoseGraphSolver::Impl {
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pattern; ///< analysed structure
  std::size_t pattern_n = 0;
  bool factorised = false;
};

PoseGraphSolver::PoseGraphSolver()
    : impl_(new Impl)
{}
PoseGraphSolver::~PoseGraphSolver() = default;

bool
PoseGraphSolver::solve(std::size_t num_vertices,
                       const std::vector<LinkBlock, Eigen::aligned_allocator<LinkBlock>>& links,
                       std::vector<Vector6d, Eigen::aligned_allocator<Vector6d>>& delta)
{
  delta.assign(num_vertices, Vector6d::Zero());
  impl_->factorised = false;
  if (num_vertices < 2)
    return true;
  const Eigen::Index dim = static_cast<Eigen::Index>(6 * (num_vertices - 1));

  // Triplets in link order (deterministic); vertex v maps to rows 6 (v - 1).
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(links.size() * 4 * 36);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(dim);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pattern;
  auto block = [&](std::uint32_t r, std::uint32_t c, const Matrix6d& m, double sign) {
    const Eigen::Index r0 = 6 * (static_cast<Eigen::Index>(r) - 1);
    const Eigen::Index c0 = 6 * (static_cast<Eigen::Index>(c) - 1);
    for (int j = 0; j < 6; ++j)
      for (int i = 0; i < 6; ++i)
        if (r0 + i >= c0 + j) // lower triangle: what SimplicialLDLT reads
          triplets.emplace_back(r0 + i, c0 + j, sign * m(i, j));
  };
  for (const LinkBlock& l : links) {
    if (!l.valid)
      continue;
    pattern.emplace_back(l.source, l.target);
    const std::uint32_t s = l.source, t = l.target;
    if (s > 0) {
      block(s, s, l.info, 1.0);
      b.segment<6>(6 * (s - 1)) -= l.grad;
    }
    if (t > 0) {
      block(t, t, l.info, 1.0);
      b.segment<6>(6 * (t - 1)) += l.grad;
    }
    if (s > 0 && t > 0) {
      if (s > t)
        block(s, t, l.info, -1.0);
      else
        block(t, s, l.info, -1.0); // info is symmetric
    }
  }
  Eigen::SparseMatrix<double> g(dim, dim);
  g.setFromTriplets(triplets.begin(), triplets.end());

  if (pattern != impl_->pattern || impl_->pattern_n != num_vertices) {
    impl_->ldlt.analyzePattern(g);
    impl_->pattern = std::move(pattern);
    impl_->pattern_n = num_vertices;
  }
  impl_->ldlt.factorize(g);
  if (impl_->ldlt.info() != Eigen::Success)
    return false;
  // LDL^T of an SPD matrix has a positive D; a zero or negative pivot means a vertex
  // is not constrained.
  if (!(impl_->ldlt.vectorD().minCoeff() > 0.0))
    return false;
  const Eigen::VectorXd x = impl_->ldlt.solve(b);
  if (impl_->ldlt.info() != Eigen::Success || !x.allFinite())
    return false;
  for (std::size_t v = 1; v < num_vertices; ++v)
    delta[v] = x.segment<6>(static_cast<Eigen::Index>(6 * (v - 1)));
  impl_->factorised = true;
  return true;
}

Matrix6d
PoseGraphSolver::covariance(std::size_t v) const
{
  if (v == 0 || !impl_->factorised || v >= impl_->pattern_n)
    return Matrix6d::Zero();
  const Eigen::Index dim = static_cast<Eigen::Index>(6 * (impl_->pattern_n - 1));
  Eigen::MatrixXd e = Eigen::MatrixXd::Zero(dim, 6);
  for (int k = 0; k < 6; ++k)
    e(static_cast<Eigen::Index>(6 * (v - 1)) + k, k) = 1.0;
  const Eigen::MatrixXd x = impl_->ldlt.solve(e);
  return x.middleRows<6>(static_cast<Eigen::Index>(6 * (v - 1)));
}

std::vector<std::uint32_t>
unreachableFromZero(std::size_t num_vertices,
                    const std::vector<std::pair<std::uint32_t, std::uint32_t>>& links)
{
  std::vector<std::uint32_t> parent(num_vertices);
  std::iota(parent.begin(), parent.end(), 0u);
  auto find = [&](std::uint32_t x) {
    while (parent[x] != x)
      x = parent[x] = parent[parent[x]];
    return x;
  };
  for (const auto& l : links)
    if (l.first < num_vertices && l.second < num_vertices)
      parent[find(l.first)] = find(l.second);
  std::vector<std::uint32_t> out;
  if (num_vertices == 0)
    return out;
  const std::uint32_t root = find(0);
  for (std::uint32_t v = 1; v < num_vertices; ++v)
    if (find(v) != root)
      out.push_back(v);
  return out;
}

} // namespace lum
} // namespace pcl_parallel
