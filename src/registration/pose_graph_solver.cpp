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
