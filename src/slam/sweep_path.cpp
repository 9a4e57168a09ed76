/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/reduction.h>
#include <pcl_parallel/registration/icp_factors.h>
#include <pcl_parallel/slam/preprocess.h>
#include <pcl_parallel/slam/sweep_path.h>

#include <Eigen/Cholesky>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pcl_parallel {
namespace slam {

namespace {
/** Converged when no knot moves by more than this (rad, m). */
constexpr double kConverged = 1e-6;
/** The accelerations a path's prior allows for (rad/s², m/s²): a scanner's velocity
 *  changes faster than this only where its points show it. */
constexpr double kAngularAcceleration = 0.2;
constexpr double kAcceleration = 0.2;

/** Piece j and fraction a of sweep time t: path(t) = knot_j (knot_j⁻¹ knot_j+1)^a. */
std::pair<int, double>
pieceOf(double t, int pieces)
{
  const double x = std::clamp(t, 0.0, 1.0) * pieces;
  const int j = std::min(static_cast<int>(x), pieces - 1);
  return {j, x - j};
}

/** The world motion ε = (ω, t) about `c`: x ↦ c + R(ω)(x - c) + t. */
Pose
motionAbout(const Eigen::Matrix<double, 6, 1>& e, const Eigen::Vector3d& c)
{
  Pose m = Pose::Identity();
  const Eigen::Matrix3d r = so3Exp(e.head<3>());
  m.topLeftCorner<3, 3>() = r;
  m.topRightCorner<3, 1>() = c - r * c + e.tail<3>();
  return m;
}

/** The normal equations over all knots, summed per block of points. */
struct PathEquations {
  Eigen::MatrixXd h;
  Eigen::VectorXd g;
  double w = 0.0;
};

/** Adds a knot-difference residual e (rotation, translation) with weights (wr, wt) and
 *  coefficients a_k on knots k (first order in each knot's world motion about c). */
void
addDifference(PathEquations& eq,
              const Poses& knots,
              const std::vector<std::pair<int, double>>& terms,
              const Eigen::Matrix<double, 6, 1>& e,
              const Eigen::Vector3d& c,
              double wr,
              double wt)
{
  const int n = static_cast<int>(eq.g.size());
  Eigen::MatrixXd j = Eigen::MatrixXd::Zero(6, n);
  for (const auto& [k, a] : terms) {
    const Eigen::Vector3d tk = knots[static_cast<std::size_t>(k)].topRightCorner<3, 1>();
    j.block<3, 3>(0, 6 * k) += a * Eigen::Matrix3d::Identity();
    j.block<3, 3>(3, 6 * k) -= a * skew(tk - c);
    j.block<3, 3>(3, 6 * k + 3) += a * Eigen::Matrix3d::Identity();
  }
  Eigen::Matrix<double, 6, 1> w;
  w << wr, wr, wr, wt, wt, wt;
  eq.h += j.transpose() * w.asDiagonal() * j;
  eq.g += j.transpose() * w.asDiagonal() * e;
}

/** The rotation and translation from pose a to b in world terms: (log(R_b R_aᵀ), t_b - t_a). */
Eigen::Matrix<double, 6, 1>
worldStep(const Pose& a, const Pose& b)
{
  Eigen::Matrix<double, 6, 1> s;
  s.head<3>() = so3Log(b.topLeftCorner<3, 3>() * a.topLeftCorner<3, 3>().transpose());
  s.tail<3>() = b.topRightCorner<3, 1>() - a.topRightCorner<3, 1>();
  return s;
}

/** The prior's terms: the path's bends, the second differences of its knots. */
void
addPrior(PathEquations& eq,
         const Poses& knots,
         const SweepPathPrior& prior,
         const Eigen::Vector3d& c)
{
  const double s2 = prior.point_sigma * prior.point_sigma;
  const double wr = s2 / (prior.bend_rotation * prior.bend_rotation),
               wt = s2 / (prior.bend_translation * prior.bend_translation);
  for (int j = 1; j + 1 < static_cast<int>(knots.size()); ++j) {
    const Eigen::Matrix<double, 6, 1> e =
        worldStep(knots[j], knots[j + 1]) - worldStep(knots[j - 1], knots[j]);
    addDifference(eq, knots, {{j - 1, 1.0}, {j, -2.0}, {j + 1, 1.0}}, e, c, wr, wt);
  }
}
} // namespace

SweepPathPrior
SweepPathPrior::forSweep(double seconds, int pieces)
{
  const double dt = seconds / pieces;
  SweepPathPrior p;
  p.bend_rotation = kAngularAcceleration * dt * dt;
  p.bend_translation = kAcceleration * dt * dt;
  return p;
}

SweepPath::SweepPath(const Pose& mid, const Pose& sweep, int pieces)
{
  if (pieces < 1)
    throw std::invalid_argument("SweepPath: pieces must be at least 1");
  for (int j = 0; j <= pieces; ++j)
    knots_.push_back(mid * interpolateMotion(sweep, static_cast<double>(j) / pieces - 0.5));
}

Pose
SweepPath::at(double t) const
{
  const auto [j, a] = pieceOf(t, static_cast<int>(knots_.size()) - 1);
  const Pose& k = knots_[static_cast<std::size_t>(j)];
  return k * interpolateMotion(Pose(k.inverse() * knots_[static_cast<std::size_t>(j) + 1]), a);
}

namespace {
/** The pieces' motions, knot_j⁻¹ knot_j+1, for poseAt. */
std::vector<Pose>
piecesOf(const SweepPath& path)
{
  std::vector<Pose> out;
  const Poses& k = path.knots();
  for (std::size_t j = 0; j + 1 < k.size(); ++j)
    out.push_back(k[j].inverse() * k[j + 1]);
  return out;
}

/** The path's pose at sweep time t, from its pieces' motions: knot_j piece_j^a. */
Pose
poseAt(const SweepPath& path, const std::vector<Pose>& pieces, double t)
{
  const auto [j, a] = pieceOf(t, static_cast<int>(pieces.size()));
  const auto k = static_cast<std::size_t>(j);
  return path.knots()[k] * interpolateMotion(pieces[k], a);
}
} // namespace

Cloud::Ptr
deskewAlong(const Cloud& scan,
            const std::vector<float>& times,
            const SweepPath& path,
            unsigned num_threads)
{
  if (times.size() != scan.size())
    throw std::invalid_argument("deskewAlong: one time per point");
  const Pose to_mid = path.mid().inverse();
  const std::vector<Pose> pieces = piecesOf(path);
  Cloud::Ptr out(new Cloud(scan));
  parallelFor(scan.size(), num_threads, 1024, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const Pose p = to_mid * poseAt(path, pieces, times[i]);
      const Eigen::Vector3d x = scan[i].getVector3fMap().cast<double>();
      (*out)[i].getVector3fMap() =
          (p.topLeftCorner<3, 3>() * x + p.topRightCorner<3, 1>()).cast<float>();
    }
  });
  return out;
}

bool
fitSweepPath(SweepPath& path,
             const Cloud& scan,
             const std::vector<float>& times,
             const MapCloud& map,
             const KdTreeIndex& map_index,
             double gate,
             const SweepPathPrior& prior,
             int max_iterations,
             unsigned num_threads)
{
  const int pieces = static_cast<int>(path.knots().size()) - 1;
  const int dim = 6 * (pieces + 1);
  const std::size_t n = scan.size();
  const registration::RobustKernel kernel{registration::RobustKernel::Type::kGemanMcClure,
                                          gate / 9.0};
  std::vector<float> queries(3 * n), sqr(n);
  std::vector<std::uint32_t> pos(n);
  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    const Eigen::Vector3d c = path.mid().topRightCorner<3, 1>();
    const std::vector<Pose> moves = piecesOf(path);
    parallelFor(n, num_threads, 1024, [&](std::size_t begin, std::size_t end) {
      for (std::size_t i = begin; i < end; ++i) {
        const Pose p = poseAt(path, moves, times[i]);
        const Eigen::Vector3d x =
            p.topLeftCorner<3, 3>() * scan[i].getVector3fMap().cast<double>() +
            p.topRightCorner<3, 1>();
        for (int d = 0; d < 3; ++d)
          queries[3 * i + d] = static_cast<float>(x[d]);
      }
    });
    map_index.nearestBatch(queries.data(),
                           n,
                           3,
                           static_cast<float>(gate * gate),
                           pos.data(),
                           sqr.data(),
                           num_threads);
    PathEquations zero{Eigen::MatrixXd::Zero(dim, dim), Eigen::VectorXd::Zero(dim), 0.0};
    PathEquations eq = deterministicReduce(
        n,
        num_threads,
        zero,
        [&](std::size_t begin, std::size_t end) {
          PathEquations b = zero;
          for (std::size_t i = begin; i < end; ++i) {
            if (pos[i] == KdTreeIndex::kInvalid)
              continue;
            const MapPoint& m = map[map_index.id(pos[i])];
            const Eigen::Vector3d nrm(m.normal_x, m.normal_y, m.normal_z);
            if (!nrm.allFinite() || nrm.squaredNorm() < 0.5)
              continue;
            const Eigen::Vector3d x(queries[3 * i], queries[3 * i + 1], queries[3 * i + 2]);
            const double r = nrm.dot(x - m.getVector3fMap().cast<double>());
            const double w = kernel.weight(r * r);
            Eigen::Matrix<double, 6, 1> jac;
            jac << (x - c).cross(nrm), nrm;
            const auto [j, a] = pieceOf(times[i], pieces);
            const double f[2] = {1.0 - a, a};
            for (int u = 0; u < 2; ++u) {
              b.g.segment<6>(6 * (j + u)) += w * f[u] * r * jac;
              for (int v = 0; v < 2; ++v)
                b.h.block<6, 6>(6 * (j + u), 6 * (j + v)) +=
                    (w * f[u] * f[v]) * (jac * jac.transpose());
            }
            b.w += w;
          }
          return b;
        },
        [](PathEquations& into, const PathEquations& from) {
          into.h += from.h;
          into.g += from.g;
          into.w += from.w;
        });
    if (!(eq.w > static_cast<double>(dim)))
      return false;
    addPrior(eq, path.knots(), prior, c);
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(eq.h);
    if (ldlt.info() != Eigen::Success)
      return false;
    const Eigen::VectorXd step = ldlt.solve(-eq.g);
    if (!step.allFinite())
      return false;
    for (int k = 0; k <= pieces; ++k) {
      Pose& knot = path.knots()[static_cast<std::size_t>(k)];
      knot = orthonormalized(motionAbout(step.segment<6>(6 * k), c) * knot);
    }
    if (step.cwiseAbs().maxCoeff() < kConverged)
      break;
  }
  return true;
}

} // namespace slam
} // namespace pcl_parallel
