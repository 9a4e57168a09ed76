/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/registration/pose_graph_solver.h>

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>

#include <numeric>

namespace pcl_parallel {
namespace lum {

namespace {

/** The components of an update (t, ω) solved for: all six, or the planar t_x, t_y, ω_z. */
constexpr int kAll[6] = {0, 1, 2, 3, 4, 5};
constexpr int kPlanar[3] = {0, 1, 5};

} // namespace

struct PoseGraphSolver::Impl {
  const int* dofs = kAll; ///< the solved components of each vertex's update
  Eigen::Index k = 6;     ///< how many
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> ldlt;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pattern; ///< analysed structure
  std::size_t pattern_n = 0;
  bool factorised = false;
};

PoseGraphSolver::PoseGraphSolver()
    : impl_(new Impl)
{}
PoseGraphSolver::~PoseGraphSolver() = default;

void
PoseGraphSolver::setPlanar(bool planar)
{
  if ((impl_->k == 3) == planar)
    return;
  impl_->dofs = planar ? kPlanar : kAll;
  impl_->k = planar ? 3 : 6;
  impl_->pattern.clear(); // another structure: analysed again
  impl_->factorised = false;
}

bool
PoseGraphSolver::solve(std::size_t num_vertices,
                       const std::vector<LinkBlock, Eigen::aligned_allocator<LinkBlock>>& links,
                       std::vector<Vector6d, Eigen::aligned_allocator<Vector6d>>& delta)
{
  delta.assign(num_vertices, Vector6d::Zero());
  impl_->factorised = false;
  if (num_vertices < 2)
    return true;
  const int* dofs = impl_->dofs;
  const Eigen::Index k = impl_->k;
  const Eigen::Index dim = k * static_cast<Eigen::Index>(num_vertices - 1);

  // Triplets in link order (deterministic); vertex v maps to rows k (v - 1).
  std::vector<Eigen::Triplet<double>> triplets;
  triplets.reserve(links.size() * 4 * k * k);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(dim);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pattern;
  auto block = [&](std::uint32_t r, std::uint32_t c, const Matrix6d& m, double sign) {
    const Eigen::Index r0 = k * (static_cast<Eigen::Index>(r) - 1);
    const Eigen::Index c0 = k * (static_cast<Eigen::Index>(c) - 1);
    for (Eigen::Index j = 0; j < k; ++j)
      for (Eigen::Index i = 0; i < k; ++i)
        if (r0 + i >= c0 + j) // lower triangle: what SimplicialLDLT reads
          triplets.emplace_back(r0 + i, c0 + j, sign * m(dofs[i], dofs[j]));
  };
  auto add = [&](std::uint32_t v, const Vector6d& grad, double sign) {
    for (Eigen::Index i = 0; i < k; ++i)
      b[k * (static_cast<Eigen::Index>(v) - 1) + i] += sign * grad[dofs[i]];
  };
  for (const LinkBlock& l : links) {
    if (!l.valid)
      continue;
    pattern.emplace_back(l.source, l.target);
    const std::uint32_t s = l.source, t = l.target;
    if (s > 0) {
      block(s, s, l.info, 1.0);
      add(s, l.grad, -1.0);
    }
    if (t > 0) {
      block(t, t, l.info, 1.0);
      add(t, l.grad, 1.0);
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
    for (Eigen::Index i = 0; i < k; ++i)
      delta[v][dofs[i]] = x[k * static_cast<Eigen::Index>(v - 1) + i];
  impl_->factorised = true;
  return true;
}

Matrix6d
PoseGraphSolver::covariance(std::size_t v) const
{
  if (v == 0 || !impl_->factorised || v >= impl_->pattern_n)
    return Matrix6d::Zero();
  const Eigen::Index k = impl_->k;
  const Eigen::Index dim = k * static_cast<Eigen::Index>(impl_->pattern_n - 1);
  const Eigen::Index row = k * static_cast<Eigen::Index>(v - 1);
  Eigen::MatrixXd e = Eigen::MatrixXd::Zero(dim, k);
  for (Eigen::Index i = 0; i < k; ++i)
    e(row + i, i) = 1.0;
  const Eigen::MatrixXd x = impl_->ldlt.solve(e);
  Matrix6d c = Matrix6d::Zero();
  for (Eigen::Index i = 0; i < k; ++i)
    for (Eigen::Index j = 0; j < k; ++j)
      c(impl_->dofs[i], impl_->dofs[j]) = x(row + i, j);
  return c;
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
