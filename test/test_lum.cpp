/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * ParallelLUM (pLUM, paper Sec. III/V): API compatibility with pcl::registration::LUM,
 * agreement with it, convergence on synthetic graphs and on the Stanford bunny, any
 * orientation, determinism over thread counts, and bad input.
 */
#include "synthetic_graph.h"
#include "test_data.h"

#include <pcl_parallel/io/stanford.h>
#include <pcl_parallel/normal_estimation.h>
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/registration/lum.h>
#include <pcl_parallel/registration/pose_graph_solver.h>

#include <pcl/common/transforms.h>
#include <pcl/console/print.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/lum.h>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <gtest/gtest.h>
#include <iterator>
#include <limits>
#include <random>
#include <tuple>

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Poses = std::vector<Eigen::Matrix4d>;
using pcl_parallel::ParallelLUM;
constexpr double kDeg = M_PI / 180.0;

Eigen::Matrix4d
makePose(double x, double y, double z, double roll, double pitch, double yaw)
{
  Eigen::Matrix<float, 6, 1> p;
  p << static_cast<float>(x), static_cast<float>(y), static_cast<float>(z),
      static_cast<float>(roll), static_cast<float>(pitch), static_cast<float>(yaw);
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  m.topRightCorner<3, 1>() = Eigen::Vector3d(x, y, z);
  return m;
}

using pcl_parallel::test::perturb;

struct Errors {
  double max_rot = 0, mean_rot = 0, max_trans = 0, mean_trans = 0;
};

Errors
poseErrors(const Poses& a, const Poses& b)
{
  Errors e;
  for (std::size_t v = 1; v < a.size(); ++v) {
    const auto [r, t] = pcl_parallel::poseError(a[v], b[v]);
    e.max_rot = std::max(e.max_rot, r);
    e.max_trans = std::max(e.max_trans, t);
    e.mean_rot += r / static_cast<double>(a.size() - 1);
    e.mean_trans += t / static_cast<double>(a.size() - 1);
  }
  return e;
}

Eigen::Vector6f
toPclPose(const Eigen::Matrix4d& m)
{
  return pcl_parallel::matrixToPose(m);
}

/** Links between every pair of n scans, (i, j) with i < j, sorted. */
std::vector<std::pair<std::uint32_t, std::uint32_t>>
allPairs(std::size_t n)
{
  std::vector<std::pair<std::uint32_t, std::uint32_t>> links;
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::uint32_t j = i + 1; j < n; ++j)
      links.emplace_back(i, j);
  return links;
}

using pcl_parallel::test::makeGraph;
using pcl_parallel::test::SyntheticGraph;

Poses
perturbAll(const Poses& truth, double angle, double dist, std::uint32_t seed)
{
  std::mt19937 rng(seed);
  Poses out = truth;
  for (std::size_t v = 1; v < truth.size(); ++v)
    out[v] = perturb(truth[v], angle, dist, rng);
  return out;
}

/** Five poses with small rotations (< 10 deg), a chain plus two cross links: the
 *  well-conditioned case where PCL's Euler-angle linearisation is valid (measured here: it
 *  diverges for the same graph with yaw up to 160 deg). */
SyntheticGraph
smallGraph()
{
  const Poses truth = {makePose(0, 0, 0, 0, 0, 0),
                       makePose(1.0, 0.2, 0.1, 0.05, -0.08, 0.1),
                       makePose(1.5, 1.2, -0.1, -0.06, 0.04, 0.15),
                       makePose(0.3, 1.6, 0.2, 0.08, 0.02, -0.1),
                       makePose(-0.5, 0.8, 0.0, -0.03, -0.07, 0.05)};
  return makeGraph(truth, {{0, 1}, {1, 2}, {2, 3}, {3, 4}, {4, 0}, {1, 3}}, 200, 1.0, 0.001, 7);
}

template <typename Lum>
Poses
posesOf(const Lum& lum)
{
  Poses out;
  for (std::size_t v = 0; v < lum.getNumVertices(); ++v)
    out.push_back(lum.getTransformation(v).matrix().template cast<double>());
  return out;
}

/** Every vertex's pose as ParallelLUM keeps it, in double (getPoseMatrix). */
Poses
poseMatricesOf(const ParallelLUM<pcl::PointXYZ>& lum)
{
  Poses out;
  for (std::size_t v = 0; v < lum.getNumVertices(); ++v)
    out.push_back(lum.getPoseMatrix(v));
  return out;
}

class QuietPcl : public ::testing::Test {
protected:
  void
  SetUp() override
  {
    pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
  }
};

// ---------------------------------------------------------------------------------------
// Drop-in: the same code, written once, for PCL's class and ours.
template <typename T>
class LumApiTest : public QuietPcl {};
using LumTypes =
    ::testing::Types<pcl::registration::LUM<pcl::PointXYZ>, ParallelLUM<pcl::PointXYZ>>;
TYPED_TEST_SUITE(LumApiTest, LumTypes);

TYPED_TEST(LumApiTest, SameCodeCompilesAndRecoversTruth)
{
  using Lum = TypeParam;
  const SyntheticGraph sg = smallGraph();
  const Poses start = perturbAll(sg.truth, 2.0 * kDeg, 0.003, 11);

  Lum lum;
  lum.setMaxIterations(10);
  EXPECT_EQ(lum.getMaxIterations(), 10);
  lum.setConvergenceThreshold(1e-9f);
  EXPECT_FLOAT_EQ(lum.getConvergenceThreshold(), 1e-9f);
  for (std::size_t v = 0; v < sg.clouds.size(); ++v) {
    const typename Lum::Vertex vx = lum.addPointCloud(sg.clouds[v], toPclPose(start[v]));
    EXPECT_EQ(static_cast<std::size_t>(vx), v);
  }
  EXPECT_EQ(lum.getNumVertices(), sg.clouds.size());
  lum.setPointCloud(2, sg.clouds[2]);
  EXPECT_EQ(lum.getPointCloud(2), sg.clouds[2]);
  lum.setPose(1, toPclPose(start[1]));
  EXPECT_TRUE(lum.getPose(1).isApprox(toPclPose(start[1])));
  EXPECT_TRUE(lum.getPose(0).isZero()); // vertex 0 is the reference
  for (const auto& [i, j, corrs] : sg.links)
    lum.setCorrespondences(i, j, corrs);
  EXPECT_EQ(lum.getCorrespondences(1, 2), std::get<2>(sg.links[1]));

  lum.compute();

  // The optimum of noisy pairs (1 mm noise, 200 pairs per link, 1-2 m lever arms) lies
  // ~0.35 mm / 0.01 deg from the truth; both classes end there.
  const Errors e = poseErrors(posesOf(lum), sg.truth);
  EXPECT_LT(e.max_rot, 0.05 * kDeg);
  EXPECT_LT(e.max_trans, 1e-3);
  const Eigen::Matrix4f from_pose =
      pcl_parallel::poseToMatrix(lum.getPose(3)).template cast<float>();
  EXPECT_TRUE(lum.getTransformation(3).matrix().isApprox(from_pose, 1e-4f));
  const typename Lum::PointCloudPtr moved = lum.getTransformedCloud(1);
  ASSERT_EQ(moved->size(), sg.clouds[1]->size());
  // A pair of link (0, 1) lands on itself in the world frame.
  const pcl::Correspondence& c = (*std::get<2>(sg.links[0]))[0];
  EXPECT_LT(((*moved)[c.index_match].getVector3fMap() -
             (*sg.clouds[0])[c.index_query].getVector3fMap())
                .norm(),
            0.02f);
  std::size_t total = 0;
  for (const auto& cl : sg.clouds)
    total += cl->size();
  EXPECT_EQ(lum.getConcatenatedCloud()->size(), total);

  const Lum copy = lum; // copyable, like PCL's
  EXPECT_EQ(copy.getNumVertices(), lum.getNumVertices());
  typename Lum::SLAMGraphPtr graph = lum.getLoopGraph();
  Lum other;
  other.setLoopGraph(graph);
  EXPECT_EQ(other.getNumVertices(), lum.getNumVertices());
  EXPECT_TRUE(other.getPose(4).isApprox(lum.getPose(4)));
}

// PCL's LUM and ours exchange graphs: our graph type is PCL's.
TEST_F(QuietPcl, GraphIsInterchangeableWithPcl)
{
  static_assert(std::is_same_v<ParallelLUM<pcl::PointXYZ>::SLAMGraph,
                               pcl::registration::LUM<pcl::PointXYZ>::SLAMGraph>);
  const SyntheticGraph sg = smallGraph();
  const Poses start = perturbAll(sg.truth, 2.0 * kDeg, 0.003, 12);
  pcl::registration::LUM<pcl::PointXYZ> pcl_lum;
  for (std::size_t v = 0; v < sg.clouds.size(); ++v)
    pcl_lum.addPointCloud(sg.clouds[v], toPclPose(start[v]));
  for (const auto& [i, j, corrs] : sg.links)
    pcl_lum.setCorrespondences(i, j, corrs);
  ParallelLUM<pcl::PointXYZ> ours;
  ours.setLoopGraph(pcl_lum.getLoopGraph()); // poses and links come with the graph
  ours.setMaxIterations(10);
  ours.compute();
  EXPECT_LT(poseErrors(posesOf(ours), sg.truth).max_rot, 0.05 * kDeg);
  // ... and PCL sees our result through the shared graph.
  EXPECT_TRUE(pcl_lum.getPose(2).isApprox(ours.getPose(2)));
}

struct OneStep {
  Errors start, pcl, ours, diff;
};

OneStep
oneIterationBoth(double angle, double dist)
{
  const SyntheticGraph sg = smallGraph();
  const Poses start = perturbAll(sg.truth, angle, dist, 13);
  pcl::registration::LUM<pcl::PointXYZ> pcl_lum;
  ParallelLUM<pcl::PointXYZ> ours;
  for (std::size_t v = 0; v < sg.clouds.size(); ++v) {
    pcl_lum.addPointCloud(sg.clouds[v], toPclPose(start[v]));
    ours.addPointCloud(sg.clouds[v], toPclPose(start[v]));
  }
  for (const auto& [i, j, corrs] : sg.links) {
    pcl_lum.setCorrespondences(i, j, corrs);
    ours.setCorrespondences(i, j, corrs);
  }
  pcl_lum.setMaxIterations(1);
  ours.setMaxIterations(1);
  pcl_lum.compute();
  ours.compute();
  const Poses p_pcl = posesOf(pcl_lum), p_ours = posesOf(ours);
  OneStep r{poseErrors(start, sg.truth),
            poseErrors(p_pcl, sg.truth),
            poseErrors(p_ours, sg.truth),
            poseErrors(p_ours, p_pcl)};
  std::printf("start %.4f deg %.3f mm | pcl %.4f deg %.3f mm | ours %.4f deg %.3f mm | "
              "diff %.4f deg %.4f mm\n",
              r.start.max_rot / kDeg,
              r.start.max_trans * 1e3,
              r.pcl.max_rot / kDeg,
              r.pcl.max_trans * 1e3,
              r.ours.max_rot / kDeg,
              r.ours.max_trans * 1e3,
              r.diff.max_rot / kDeg,
              r.diff.max_trans * 1e3);
  return r;
}

// One iteration with fixed correspondences agrees with PCL's. Both are Gauss-Newton-type
// steps on the same pairs with the same link weights (every link has the same pair count,
// so PCL's unnormalised s^2 weights the links as our SSR / (3N - 6) does), and both rotate
// a pose about its own position, so the translations agree to rounding (< 0.01 mm). The
// rotations differ by PCL's linearisation error: it adds Euler-angle increments through an
// approximate incidence correction, an error of order e * theta in the start error e and
// the pose's rotation theta (<= 0.16 rad here), where ours is O(e^2). The Euler-rate to
// angular-velocity map differs from the identity by up to two O(theta) entries per row,
// hence the tolerance 2 * e * theta_max; and the difference must shrink with e (measured:
// linearly; 0.26 deg at e = 2 deg, 0.075 deg at 0.5 deg with GCC -O3, 0.34 deg at 2 deg
// with clang -O1, PCL's float arithmetic being compiled differently; ours alone lands at
// the 0.01-0.02 deg noise floor).
TEST_F(QuietPcl, OneIterationAgreesWithPcl)
{
  const double theta_max = 0.16;
  const OneStep big = oneIterationBoth(2.0 * kDeg, 0.003);
  const OneStep small = oneIterationBoth(0.5 * kDeg, 0.00075);
  EXPECT_LT(big.diff.max_rot, 2.0 * theta_max * big.start.max_rot);
  EXPECT_LT(small.diff.max_rot, 2.0 * theta_max * small.start.max_rot);
  EXPECT_LT(big.diff.max_trans, 1e-5);
  EXPECT_LT(small.diff.max_rot, big.diff.max_rot / 3.0);
  // Both steps are real improvements, ours at least as good as PCL's.
  EXPECT_LT(big.pcl.max_rot, 0.2 * big.start.max_rot);
  EXPECT_LT(big.ours.max_rot, 0.2 * big.start.max_rot);
  EXPECT_LE(big.ours.max_rot, big.pcl.max_rot);
  EXPECT_LT(big.ours.max_trans, 0.3 * big.start.max_trans);
}

// ---------------------------------------------------------------------------------------
// Any orientation: poses at and near pitch +-90 deg (gimbal lock of the 6-vector).
TEST_F(QuietPcl, GimbalLockPosesConverge)
{
  const Poses truth = {makePose(0, 0, 0, 0, 0, 0),
                       makePose(0.8, 0.1, 0.0, 0.3, M_PI / 2, -0.2),
                       makePose(1.2, 0.9, 0.1, 0.0, -M_PI / 2, 0.7),
                       makePose(0.2, 1.1, -0.1, 1.0, M_PI / 2 - 1e-4, 2.0),
                       makePose(-0.6, 0.5, 0.2, -0.4, 0.2, 3.0)};
  const SyntheticGraph sg =
      makeGraph(truth, {{0, 1}, {1, 2}, {2, 3}, {3, 4}, {4, 0}, {0, 2}}, 200, 1.0, 0.001, 21);
  const Poses start = perturbAll(truth, 3.0 * kDeg, 0.005, 22);
  ParallelLUM<pcl::PointXYZ> lum;
  for (std::size_t v = 0; v < truth.size(); ++v)
    lum.addPointCloud(sg.clouds[v], Eigen::Matrix4f(start[v].cast<float>()));
  for (const auto& [i, j, corrs] : sg.links)
    lum.setCorrespondences(i, j, corrs);
  lum.setMaxIterations(10);
  lum.compute();
  Poses got;
  for (std::size_t v = 0; v < truth.size(); ++v)
    got.push_back(lum.getPoseMatrix(v));
  const Errors e = poseErrors(got, truth);
  EXPECT_LT(e.max_rot, 0.05 * kDeg); // noise-limited optimum: ~0.013 deg, 0.2 mm
  EXPECT_LT(e.max_trans, 0.5e-3);
  // The 6-vector boundary stays consistent at the lock: it maps back to the same matrix.
  for (std::size_t v = 1; v < truth.size(); ++v) {
    const auto [r, t] =
        pcl_parallel::poseError(pcl_parallel::poseToMatrix(lum.getPose(v)), got[v]);
    EXPECT_LT(r, 1e-5) << "vertex " << v;
    EXPECT_LT(t, 1e-6) << "vertex " << v;
  }
}

TEST(LumMath, PoseRoundTripAtAnyPitch)
{
  for (double pitch : {-M_PI / 2, -1.2, 0.0, 0.7, M_PI / 2 - 1e-7, M_PI / 2}) {
    const Eigen::Matrix4d m = makePose(0.1, -0.2, 0.3, 0.4, pitch, -1.1);
    const double r =
        pcl_parallel::poseError(pcl_parallel::poseToMatrix(pcl_parallel::matrixToPose(m)), m)
            .angle;
    EXPECT_LT(r, 1e-6) << "pitch " << pitch;
  }
}

// updateBetween() is the inverse of applyUpdate(), also far from the origin.
TEST(LumMath, UpdateBetweenInvertsApplyUpdate)
{
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int k = 0; k < 20; ++k) {
    Eigen::Matrix4d pose =
        makePose(100 * u(rng), 50 * u(rng), 10 * u(rng), 3 * u(rng), 1.5 * u(rng), 3 * u(rng));
    pcl_parallel::lum::Vector6d d;
    d << u(rng), u(rng), u(rng), 0.2 * u(rng), 0.2 * u(rng), 0.2 * u(rng);
    Eigen::Matrix4d moved = pose;
    pcl_parallel::lum::applyUpdate(moved, d);
    const pcl_parallel::lum::Vector6d back = pcl_parallel::lum::updateBetween(pose, moved);
    EXPECT_LT((back - d).norm(), 1e-9) << k;
  }
}

// addWeighted() with W = I is add(): the same information matrix and gradient.
TEST(LumMath, WeightedIdentityEqualsPointToPoint)
{
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  pcl_parallel::lum::LinkAccumulator plain, weighted;
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector3d a(10 + u(rng), 5 + u(rng), u(rng));
    const Eigen::Vector3d b = a + 0.01 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    plain.add(a, b);
    weighted.addWeighted(a, b, Eigen::Matrix3d::Identity());
  }
  pcl_parallel::lum::Matrix6d h1, h2;
  pcl_parallel::lum::Vector6d g1, g2;
  double s1, s2;
  ASSERT_TRUE(plain.finish(10, 0.0, h1, g1, &s1));
  ASSERT_TRUE(weighted.finish(10, 0.0, h2, g2, &s2));
  EXPECT_NEAR(s1, s2, 1e-12 * s1);
  EXPECT_LT((h1 - h2).norm(), 1e-9 * h1.norm());
  EXPECT_LT((g1 - g2).norm(), 1e-9 * g1.norm());
}

// Pairs on the three planes of a box corner, offset along their planes (as closest
// points on sampled surfaces are): point-to-plane measures the true pose difference,
// point-to-point is pulled by the offsets.
TEST(LumMath, PointToPlaneIgnoresOffsetsAlongTheSurface)
{
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  pcl_parallel::lum::Vector6d truth;
  truth << 0.01, -0.02, 0.005, 0.01, -0.005, 0.02;
  pcl_parallel::lum::LinkAccumulator plane, point;
  for (int k = 0; k < 300; ++k) {
    const int axis = k % 3;
    Eigen::Vector3d m(u(rng), u(rng), u(rng));
    m(axis) = 0.0; // on the plane with normal e_axis
    const Eigen::Vector3d n = Eigen::Vector3d::Unit(axis);
    Eigen::Vector3d slide = 0.01 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    slide(axis) = 0.0;
    Eigen::Matrix<double, 3, 6> jac;
    jac << Eigen::Matrix3d::Identity(),
        -(Eigen::Matrix3d() << 0, -m.z(), m.y(), m.z(), 0, -m.x(), -m.y(), m.x(), 0).finished();
    // Residual r = a - b with midpoint m such that r + M D vanishes at D = truth, up to
    // the slide along the plane.
    const Eigen::Vector3d r = -(jac * truth) + slide;
    plane.addWeighted(m + 0.5 * r, m - 0.5 * r, n * n.transpose());
    point.add(m + 0.5 * r, m - 0.5 * r);
  }
  pcl_parallel::lum::Vector6d d_plane, d_point;
  ASSERT_TRUE(plane.measurement(10, d_plane));
  ASSERT_TRUE(point.measurement(10, d_point));
  EXPECT_LT((d_plane - truth).norm(), 1e-9);
  EXPECT_GT((d_point - truth).norm(), 1e-3); // the offsets do bias point-to-point
}

// The Cauchy kernel of a pose constraint beside a scan link on the same vertices weighs
// the update the constraint asks for, d = J^-1 e0, in the link's information: a link with
// no information along d does not contradict it (full weight, the block of plain least
// squares), a link that constrains d does (down-weighted as by its own information), and
// without a valid link the constraint's own chi2 decides as before.
TEST(LumMath, ConstraintKernelJudgedByTheLinkBetweenItsVertices)
{
  namespace lum = pcl_parallel::lum;
  const Eigen::Matrix4d source = makePose(2.0, -1.0, 0.5, 0.1, -0.2, 0.7);
  const Eigen::Matrix4d target = makePose(0.5, 0.3, 0.0, 0.0, 0.1, 0.2);
  lum::PoseConstraint c;
  c.source = 1;
  c.target = 0;
  c.measured = target.inverse() * source;
  c.measured(0, 3) += 0.1; // 10 cm off: chi2 1e4 in its own information
  c.information = lum::Matrix6d::Identity() * 1e6;
  const lum::LinkBlock plain = lum::constraintBlock(c, source, target);
  ASSERT_TRUE(plain.valid);
  const lum::Vector6d d = plain.info.ldlt().solve(plain.grad); // J^-1 e0
  c.cauchy_scale = 16.8;
  const double own_weight = 1.0 / (1.0 + 1e4 / 16.8);
  const lum::LinkBlock alone = lum::constraintBlock(c, source, target);
  EXPECT_LT((alone.info - own_weight * plain.info).norm(), 1e-9 * plain.info.norm());

  lum::LinkBlock link;
  link.source = 1;
  link.target = 0;
  link.valid = true;
  const lum::Vector6d u = d.normalized();
  link.info = 1e6 * (lum::Matrix6d::Identity() - u * u.transpose()); // open along d
  const lum::LinkBlock open = lum::constraintBlock(c, source, target, &link);
  EXPECT_LT((open.info - plain.info).norm(), 1e-6 * plain.info.norm());
  EXPECT_LT((open.grad - plain.grad).norm(), 1e-6 * plain.grad.norm());

  link.info = lum::Matrix6d::Identity() * 1e6; // constrains d: chi2 = 1e6 |d|^2
  const double link_weight = 1.0 / (1.0 + 1e6 * d.squaredNorm() / 16.8);
  const lum::LinkBlock held = lum::constraintBlock(c, source, target, &link);
  EXPECT_LT(link_weight, 0.01);
  EXPECT_LT((held.info - link_weight * plain.info).norm(), 1e-6 * plain.info.norm());

  link.valid = false; // dropped this iteration: the constraint's own chi2
  const lum::LinkBlock dropped = lum::constraintBlock(c, source, target, &link);
  EXPECT_LT((dropped.info - alone.info).norm(), 1e-12 * plain.info.norm());
}

// ---------------------------------------------------------------------------------------
// pLUM mode: pairs re-estimated by the k-d trees every iteration.
struct PlumScene {
  Poses truth;
  std::vector<Cloud::Ptr> clouds;
};

/** Sparse random points (spacing ~5 cm, far above the start error), each scan seeing a
 *  different part of one world cloud, so closest points are the true counterparts. */
PlumScene
plumScene(const Poses& truth, std::uint32_t seed)
{
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector3d> world(8000);
  for (auto& w : world)
    w = Eigen::Vector3d(u(rng), u(rng), u(rng));
  PlumScene s;
  s.truth = truth;
  for (std::size_t v = 0; v < truth.size(); ++v) {
    Cloud::Ptr c(new Cloud);
    const Eigen::Matrix4d inv = truth[v].inverse();
    // Each scan sees the half-space in front of a scan-specific direction.
    const Eigen::Vector3d dir(std::cos(1.3 * v), std::sin(1.3 * v), 0.3);
    for (const auto& w : world) {
      if (w.dot(dir) < -0.3)
        continue;
      const Eigen::Vector3d p = inv.topLeftCorner<3, 3>() * w + inv.topRightCorner<3, 1>();
      c->push_back(pcl::PointXYZ(
          static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
    }
    s.clouds.push_back(c);
  }
  return s;
}

Poses
runPlum(const PlumScene& s,
        const Poses& start,
        const std::vector<std::pair<std::uint32_t, std::uint32_t>>& links,
        unsigned threads,
        int iterations)
{
  ParallelLUM<pcl::PointXYZ> lum;
  lum.setNumberOfThreads(threads);
  for (std::size_t v = 0; v < s.clouds.size(); ++v)
    lum.addPointCloud(s.clouds[v], Eigen::Matrix4f(start[v].cast<float>()));
  for (const auto& [i, j] : links)
    lum.addLink(i, j);
  lum.setCorrespondenceDistance(0.02);
  lum.setMaxIterations(iterations);
  lum.compute();
  EXPECT_GT(lum.getCorrespondences(links[0].first, links[0].second)->size(), 100u);
  return poseMatricesOf(lum);
}

TEST_F(QuietPcl, PlumRecoversTruthIncludingGimbalLock)
{
  const Poses truth = {makePose(0, 0, 0, 0, 0, 0),
                       makePose(0.05, 0.1, 0, 0.2, M_PI / 2, 0.1),
                       makePose(-0.1, 0.02, 0.1, 2.0, -0.5, 1.0),
                       makePose(0.1, -0.1, 0.05, -1.0, 0.3, -2.5),
                       makePose(0.0, 0.1, -0.1, 0.5, -M_PI / 2, 2.9)};
  const PlumScene s = plumScene(truth, 31);
  const Poses start = perturbAll(truth, 2.0 * kDeg, 0.003, 32);
  const auto links = allPairs(truth.size());
  ASSERT_EQ(links.size(), 10u); // all pairs of 5 close scans
  const Poses got = runPlum(s, start, links, 2, 10);
  const Errors e = poseErrors(got, truth);
  EXPECT_LT(e.max_rot, 0.01 * kDeg);
  EXPECT_LT(e.max_trans, 0.05e-3);
}

TEST_F(QuietPcl, PlumIsIdenticalForOneAndTwoThreads)
{
  const Poses truth = {makePose(0, 0, 0, 0, 0, 0),
                       makePose(0.05, 0.1, 0, 0.2, 0.4, 0.1),
                       makePose(-0.1, 0.02, 0.1, 2.0, -0.5, 1.0),
                       makePose(0.1, -0.1, 0.05, -1.0, 0.3, -2.5)};
  const PlumScene s = plumScene(truth, 41);
  const Poses start = perturbAll(truth, 2.0 * kDeg, 0.003, 42);
  const auto links = allPairs(truth.size());
  const Poses one = runPlum(s, start, links, 1, 3);
  const Poses two = runPlum(s, start, links, 2, 3);
  for (std::size_t v = 0; v < one.size(); ++v)
    EXPECT_EQ(one[v], two[v]) << "vertex " << v; // bit-identical
}

// The planar solve (Sec. VII's 2D case) against the dense system: G X = B assembled over
// all six components, reduced to the rows and columns of x, y and the yaw, solved densely;
// the other components of each update zero, the covariance G⁻¹'s planar block.
TEST(LumMath, PlanarSolveIsTheDenseSystemsPlanarBlock)
{
  namespace lum = pcl_parallel::lum;
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  const std::size_t n = 6;
  std::vector<lum::LinkBlock, Eigen::aligned_allocator<lum::LinkBlock>> links;
  for (const auto& [s, t] : std::vector<std::pair<std::uint32_t, std::uint32_t>>{
           {0, 1}, {1, 2}, {2, 3}, {3, 4}, {4, 5}, {5, 0}, {1, 4}, {3, 0}}) {
    lum::LinkBlock l;
    l.source = s;
    l.target = t;
    l.valid = true;
    lum::Matrix6d a;
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c)
        a(r, c) = g(rng);
    l.info = a * a.transpose() + lum::Matrix6d::Identity();
    for (int k = 0; k < 6; ++k)
      l.grad[k] = g(rng);
    links.push_back(l);
  }
  constexpr int kPlanar[3] = {0, 1, 5}; // t_x, t_y, ω_z
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(3 * (n - 1), 3 * (n - 1));
  Eigen::VectorXd B = Eigen::VectorXd::Zero(3 * (n - 1));
  for (const auto& l : links)
    for (int i = 0; i < 3; ++i) {
      const auto row = [&](std::uint32_t v) { return 3 * (static_cast<int>(v) - 1) + i; };
      if (l.source > 0)
        B[row(l.source)] -= l.grad[kPlanar[i]];
      if (l.target > 0)
        B[row(l.target)] += l.grad[kPlanar[i]];
      for (int j = 0; j < 3; ++j) {
        const double h = l.info(kPlanar[i], kPlanar[j]);
        const auto col = [&](std::uint32_t v) { return 3 * (static_cast<int>(v) - 1) + j; };
        if (l.source > 0)
          G(row(l.source), col(l.source)) += h;
        if (l.target > 0)
          G(row(l.target), col(l.target)) += h;
        if (l.source > 0 && l.target > 0) {
          G(row(l.source), col(l.target)) -= h;
          G(row(l.target), col(l.source)) -= h;
        }
      }
    }
  const Eigen::VectorXd x = G.ldlt().solve(B);
  const Eigen::MatrixXd cov = G.inverse();
  lum::PoseGraphSolver solver;
  solver.setPlanar(true);
  std::vector<lum::Vector6d, Eigen::aligned_allocator<lum::Vector6d>> delta;
  ASSERT_TRUE(solver.solve(n, links, delta));
  for (std::size_t v = 1; v < n; ++v) {
    const lum::Matrix6d c = solver.covariance(v);
    for (int i = 0; i < 6; ++i) {
      const int p = static_cast<int>(std::find(kPlanar, kPlanar + 3, i) - kPlanar);
      const int r = 3 * static_cast<int>(v - 1) + p;
      if (p == 3) { // not planar: no update, no covariance
        EXPECT_EQ(delta[v][i], 0.0) << v << " " << i;
        EXPECT_TRUE(c.row(i).isZero() && c.col(i).isZero()) << v << " " << i;
        continue;
      }
      EXPECT_NEAR(delta[v][i], x[r], 1e-9 * (1.0 + std::abs(x[r]))) << v << " " << i;
      for (int j = 0; j < 3; ++j)
        EXPECT_NEAR(c(i, kPlanar[j]), cov(r, 3 * static_cast<int>(v - 1) + j), 1e-9)
            << v << " " << i << " " << j;
    }
  }
  solver.setPlanar(false); // back to six components: the same system as a fresh solver
  lum::PoseGraphSolver fresh;
  std::vector<lum::Vector6d, Eigen::aligned_allocator<lum::Vector6d>> full, fresh_full;
  ASSERT_TRUE(solver.solve(n, links, full));
  ASSERT_TRUE(fresh.solve(n, links, fresh_full));
  for (std::size_t v = 0; v < n; ++v)
    EXPECT_EQ(full[v], fresh_full[v]) << v;
}

// pLUM on a horizontal 2D scanner's scans (z = 0, walls of a room with an inner wall) from
// planar poses off by up to 2 degrees and 5 cm: in planar mode the poses end at the truth
// and exactly in the plane, bit-identical for one and two threads; point-to-plane with
// the normals it estimates (in the plane: point-to-line) as well.
TEST_F(QuietPcl, PlanarPlumKeepsTwoDScansInThePlane)
{
  const Poses truth = {makePose(0, 0, 0, 0, 0, 0),
                       makePose(1.0, 0.5, 0, 0, 0, 0.35),
                       makePose(2.0, -0.5, 0, 0, 0, -0.25),
                       makePose(-1.0, 1.0, 0, 0, 0, 0.7),
                       makePose(0.5, -1.5, 0, 0, 0, 1.57)};
  std::vector<Eigen::Vector2d> world; // a wall point every 2 cm
  const double walls[][4] = {{-5, -4, 5, -4},
                             {5, -4, 5, 4},
                             {5, 4, -5, 4},
                             {-5, 4, -5, -4},
                             {-2, -4, -2, -1},
                             {2, 4, 2, 1.5}};
  for (const auto& w : walls) {
    const Eigen::Vector2d a(w[0], w[1]), b(w[2], w[3]);
    for (double s = 0.0; s < (b - a).norm(); s += 0.02)
      world.push_back(a + s * (b - a).normalized());
  }
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.003);
  PlumScene scene;
  scene.truth = truth;
  for (const auto& pose : truth) {
    Cloud::Ptr c(new Cloud);
    const Eigen::Matrix4d inv = pose.inverse();
    for (const auto& w : world) {
      const Eigen::Vector4d p = inv * Eigen::Vector4d(w.x(), w.y(), 0.0, 1.0);
      c->push_back(pcl::PointXYZ(static_cast<float>(p.x() + noise(rng)),
                                 static_cast<float>(p.y() + noise(rng)),
                                 0.0f));
    }
    scene.clouds.push_back(c);
  }
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Poses start = truth;
  for (std::size_t v = 1; v < start.size(); ++v)
    start[v] = makePose(0.05 * u(rng), 0.05 * u(rng), 0, 0, 0, 2.0 * kDeg * u(rng)) * truth[v];
  std::vector<Eigen::Vector3f> normals; // of scan 1, as point-to-plane estimated them
  const auto run = [&](unsigned threads, bool point_to_plane) {
    ParallelLUM<pcl::PointXYZ> lum;
    lum.setPlanar(true);
    lum.setPointToPlane(point_to_plane);
    lum.setNumberOfThreads(threads);
    for (std::size_t v = 0; v < scene.clouds.size(); ++v)
      lum.addPointCloud(scene.clouds[v], Eigen::Matrix4f(start[v].cast<float>()));
    for (const auto& [i, j] : allPairs(truth.size()))
      lum.addLink(i, j);
    lum.setCorrespondenceDistanceSchedule(0.3, 0.03, 0.7);
    lum.setMaxIterations(40);
    lum.compute();
    normals = lum.getPointNormals(1);
    return poseMatricesOf(lum);
  };
  for (const bool point_to_plane : {false, true}) {
    SCOPED_TRACE(point_to_plane ? "point-to-plane" : "point-to-point");
    const Poses got = run(1, point_to_plane);
    for (std::size_t v = 0; v < got.size(); ++v) {
      const Eigen::Matrix4d& p = got[v];
      EXPECT_TRUE(p(2, 0) == 0.0 && p(2, 1) == 0.0 && p(0, 2) == 0.0 && p(1, 2) == 0.0 &&
                  p(2, 2) == 1.0 && p(2, 3) == 0.0)
          << "vertex " << v << " leaves the plane:\n"
          << p;
    }
    const Errors e = poseErrors(got, truth);
    EXPECT_LT(e.max_rot, 0.02 * kDeg);
    EXPECT_LT(e.max_trans, 2e-3);
    if (pcl_parallel::test::kSanitized && point_to_plane)
      continue; // threads checked on point-to-point there (these runs take 20 s each)
    const Poses two = run(2, point_to_plane);
    for (std::size_t v = 0; v < got.size(); ++v)
      EXPECT_EQ(two[v], got[v]) << "vertex " << v;
  }
  // Normal to the walls' lines: in the plane and of unit length (each neighbourhood spreads
  // along its wall, or round a corner).
  ASSERT_EQ(normals.size(), scene.clouds[1]->size());
  std::size_t in_plane = 0;
  for (const auto& n : normals)
    in_plane += std::abs(n.z()) < 1e-6f && std::abs(n.norm() - 1.0f) < 1e-5f ? 1 : 0;
  EXPECT_EQ(in_plane, normals.size());
}

// Links in both directions (a -> b and b -> a) and repeated links, as users add loops:
// each link and search direction has its own warm-start hints, so no two threads share
// one (issue 11: a shared hint vector was reallocated under another thread; the tsan
// stage runs this). Results are bit-identical for 1-4 threads and across repeated runs,
// with and without the extra links, and still converge.
TEST_F(QuietPcl, PlumBidirectionalAndDuplicateLinksAreDeterministic)
{
  const Poses truth = {makePose(0, 0, 0, 0, 0, 0),
                       makePose(0.05, 0.1, 0, 0.2, 0.4, 0.1),
                       makePose(-0.1, 0.02, 0.1, 2.0, -0.5, 1.0),
                       makePose(0.1, -0.1, 0.05, -1.0, 0.3, -2.5)};
  const PlumScene s = plumScene(truth, 51);
  const Poses start = perturbAll(truth, 2.0 * kDeg, 0.003, 52);
  const auto plain = allPairs(truth.size());
  auto both = plain;
  for (const auto& [i, j] : plain)
    both.emplace_back(j, i); // every link reversed
  both.push_back(plain[0]);  // and repeated: twice, and its reverse once more
  both.push_back(plain[0]);
  both.emplace_back(plain[1].second, plain[1].first);
  // addLink() ignores a repeat, so links go into the graph itself (as setLoopGraph's do).
  auto run = [&](const std::vector<std::pair<std::uint32_t, std::uint32_t>>& links,
                 unsigned threads) {
    ParallelLUM<pcl::PointXYZ> lum;
    lum.setNumberOfThreads(threads);
    for (std::size_t v = 0; v < s.clouds.size(); ++v)
      lum.addPointCloud(s.clouds[v], Eigen::Matrix4f(start[v].cast<float>()));
    ParallelLUM<pcl::PointXYZ>::EdgeProperties ep;
    ep.cinv_.setZero();
    ep.cinvd_.setZero();
    for (const auto& [i, j] : links)
      boost::add_edge(i, j, ep, *lum.getLoopGraph());
    lum.setCorrespondenceDistance(0.02);
    lum.setMaxIterations(4);
    lum.compute();
    EXPECT_EQ(lum.getNumDroppedLinks(), 0u);
    return poseMatricesOf(lum);
  };
  using Links = std::decay_t<decltype(plain)>;
  for (const Links* links : std::initializer_list<const Links*>{&plain, &both}) {
    const Poses reference = run(*links, 1);
    EXPECT_LT(poseErrors(reference, truth).max_trans, 0.5e-3) << links->size() << " links";
    for (unsigned threads : {1u, 2u, 3u, 4u}) {
      const Poses got = run(*links, threads);
      for (std::size_t v = 0; v < got.size(); ++v)
        EXPECT_EQ(got[v], reference[v])
            << links->size() << " links, " << threads << " threads, vertex " << v;
    }
  }
}

// The gate schedule, the option setters' validation and the iteration callback.
/** Three scans' poses, the last one 2 m away and turned. */
Poses
threeScanPoses()
{
  return {makePose(0, 0, 0, 0, 0, 0),
          makePose(0.05, 0.1, 0, 0.2, 0.4, 0.1),
          makePose(-0.1, 0.02, 0.1, 2.0, -0.5, 1.0)};
}

// Normals given with setPointNormals (by point index) are what pLUM would estimate itself
// when they are the same numbers: bit-identical poses, so they reach each tree position
// of the right point. Other normals change the result; a wrong count is an error. The
// normals one ParallelLUM used (getPointNormals, in the cloud's order) given to another
// pair its vertex the same (how a scan moves between MPI ranks).
TEST_F(QuietPcl, PlumTakesGivenNormals)
{
  const Poses truth = threeScanPoses();
  const PlumScene s = plumScene(truth, 61);
  const Poses start = perturbAll(truth, 2.0 * kDeg, 0.003, 62);
  enum class Normals { kEstimated, kGiven, kZero, kFromAnother };
  auto run = [&](Normals mode) {
    ParallelLUM<pcl::PointXYZ> lum;
    for (std::size_t v = 0; v < s.clouds.size(); ++v)
      lum.addPointCloud(s.clouds[v], Eigen::Matrix4f(start[v].cast<float>()));
    lum.addLink(0, 1);
    lum.addLink(1, 2);
    lum.addLink(0, 2);
    lum.setPointToPlane(true);
    lum.setCorrespondenceDistance(0.05);
    lum.setMaxIterations(3);
    for (std::size_t v = 0; mode != Normals::kEstimated && v < s.clouds.size(); ++v) {
      std::vector<Eigen::Vector3f> given(s.clouds[v]->size(), Eigen::Vector3f::Zero());
      if (mode == Normals::kFromAnother) {
        ParallelLUM<pcl::PointXYZ> other;
        other.setPointToPlane(true);
        other.addPointCloud(s.clouds[v]);
        EXPECT_TRUE(other.getPointNormals(0).empty()) << "none before the tree";
        other.getSearchTree(0); // estimates them
        given = other.getPointNormals(0);
        EXPECT_EQ(given.size(), s.clouds[v]->size());
      }
      if (mode == Normals::kGiven) {
        const pcl_parallel::KdTreeIndex& tree =
            *lum.getSearchTree(v); // its normals: by tree position
        const auto by_position = pcl_parallel::estimateUnitNormals(tree, 10, 1);
        for (std::uint32_t pos = 0; pos < tree.size(); ++pos)
          given[tree.id(pos)] = by_position[pos];
      }
      lum.setPointNormals(v, given);
    }
    lum.compute();
    return poseMatricesOf(lum);
  };
  const Poses estimated = run(Normals::kEstimated), given = run(Normals::kGiven),
              zero = run(Normals::kZero), from_another = run(Normals::kFromAnother);
  for (std::size_t v = 1; v < estimated.size(); ++v) {
    EXPECT_EQ(given[v], estimated[v]) << "vertex " << v;
    EXPECT_EQ(from_another[v], estimated[v]) << "vertex " << v;
    EXPECT_NE(zero[v], estimated[v]) << "vertex " << v;
  }
  ParallelLUM<pcl::PointXYZ> lum;
  lum.addPointCloud(s.clouds[0]);
  EXPECT_THROW(lum.setPointNormals(0, std::vector<Eigen::Vector3f>(3)), std::invalid_argument);
  EXPECT_THROW(lum.setPointNormals(1, {}), std::out_of_range); // no such vertex
}

// A tree given with setSearchTree (built by the caller, on 2 threads) is the one pLUM
// searches, with the given normals mapped onto it: the same poses as with the trees pLUM
// builds itself. A tree of another size is an error.
TEST_F(QuietPcl, PlumTakesGivenTrees)
{
  const Poses truth = threeScanPoses();
  const PlumScene s = plumScene(truth, 63);
  const Poses start = perturbAll(truth, 2.0 * kDeg, 0.003, 64);
  auto run = [&](bool given) {
    ParallelLUM<pcl::PointXYZ> lum;
    lum.setPointToPlane(true);
    for (std::size_t v = 0; v < s.clouds.size(); ++v) {
      lum.addPointCloud(s.clouds[v], Eigen::Matrix4f(start[v].cast<float>()));
      if (!given)
        continue;
      const pcl::PointCloud<pcl::PointXYZ>& c = *s.clouds[v];
      auto tree = std::make_shared<pcl_parallel::KdTreeIndex>();
      tree->build(c.front().data, c.size(), 4, nullptr, 2);
      const auto by_position = pcl_parallel::estimateUnitNormals(*tree, 10, 2);
      std::vector<Eigen::Vector3f> normals(c.size());
      for (std::uint32_t pos = 0; pos < tree->size(); ++pos)
        normals[tree->id(pos)] = by_position[pos];
      lum.setPointNormals(v, normals);
      lum.setSearchTree(v, tree);
      EXPECT_EQ(lum.getSearchTree(v), tree) << "vertex " << v;
    }
    lum.addLink(0, 1);
    lum.addLink(1, 2);
    lum.addLink(0, 2);
    lum.setCorrespondenceDistance(0.05);
    lum.setMaxIterations(3);
    lum.compute();
    return poseMatricesOf(lum);
  };
  const Poses own = run(false), given = run(true);
  EXPECT_GT(poseErrors(start, truth).max_trans, 2 * poseErrors(own, truth).max_trans);
  for (std::size_t v = 0; v < own.size(); ++v)
    EXPECT_EQ(given[v], own[v]) << "vertex " << v;

  ParallelLUM<pcl::PointXYZ> lum;
  lum.addPointCloud(s.clouds[0]);
  auto other = std::make_shared<pcl_parallel::KdTreeIndex>();
  other->build(s.clouds[1]->front().data, s.clouds[1]->size() - 1, 4);
  EXPECT_THROW(lum.setSearchTree(0, other), std::invalid_argument);
  EXPECT_THROW(lum.setSearchTree(0, nullptr), std::invalid_argument);
  EXPECT_THROW(lum.setSearchTree(1, other), std::out_of_range); // no such vertex
}

TEST_F(QuietPcl, PlumOptions)
{
  ParallelLUM<pcl::PointXYZ> lum;
  EXPECT_EQ(lum.getCorrespondenceDistance(), 0.0); // PCL mode by default
  lum.setCorrespondenceDistanceSchedule(0.01, 0.002, 0.5);
  EXPECT_DOUBLE_EQ(lum.correspondenceDistanceAt(0), 0.01);
  EXPECT_DOUBLE_EQ(lum.correspondenceDistanceAt(1), 0.005);
  EXPECT_DOUBLE_EQ(lum.correspondenceDistanceAt(2), 0.0025);
  EXPECT_DOUBLE_EQ(lum.correspondenceDistanceAt(3), 0.002);
  EXPECT_DOUBLE_EQ(lum.correspondenceDistanceAt(100), 0.002);
  lum.setCorrespondenceDistance(0.03);
  EXPECT_DOUBLE_EQ(lum.correspondenceDistanceAt(7), 0.03);
  lum.setCorrespondenceDistance(0.0);
  EXPECT_EQ(lum.getCorrespondenceDistance(), 0.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(lum.setCorrespondenceDistance(nan), std::invalid_argument);
  EXPECT_THROW(lum.setCorrespondenceDistanceSchedule(0.001, 0.002, 0.9), std::invalid_argument);
  EXPECT_THROW(lum.setCorrespondenceDistanceSchedule(0.01, 0.0, 0.9), std::invalid_argument);
  EXPECT_THROW(lum.setCorrespondenceDistanceSchedule(0.01, 0.002, 0.0), std::invalid_argument);
  EXPECT_THROW(lum.setCorrespondenceDistanceSchedule(0.01, 0.002, 1.5), std::invalid_argument);
  EXPECT_THROW(lum.setCorrespondenceDistanceSchedule(nan, 0.002, 0.9), std::invalid_argument);
  EXPECT_THROW(lum.setLinkIterations(0), std::invalid_argument);
  EXPECT_THROW(lum.setPointToPointWeight(-1.0), std::invalid_argument);
  EXPECT_THROW(lum.setNormalNeighbours(2), std::invalid_argument);

  // The callback sees every iteration, with the updated poses.
  const Poses truth = threeScanPoses();
  const PlumScene s = plumScene(truth, 51);
  const Poses start = perturbAll(truth, 2.0 * kDeg, 0.003, 52);
  for (std::size_t v = 0; v < s.clouds.size(); ++v)
    lum.addPointCloud(s.clouds[v], Eigen::Matrix4f(start[v].cast<float>()));
  lum.addLink(1, 0);
  lum.addLink(2, 1);
  lum.setCorrespondenceDistanceSchedule(0.04, 0.02, 0.5);
  lum.setMaxIterations(4);
  std::vector<int> seen;
  Eigen::Matrix4d last;
  lum.setIterationCallback([&](int it, double mean_update) {
    seen.push_back(it);
    EXPECT_GE(mean_update, 0.0);
    last = lum.getPoseMatrix(2);
  });
  lum.compute();
  EXPECT_EQ(seen, (std::vector<int>{0, 1, 2, 3}));
  EXPECT_EQ(last, lum.getPoseMatrix(2));
  // Convergence only counts once the gate has shrunk to its end (iteration 1).
  lum.setConvergenceThreshold(1e30f);
  lum.compute();
  EXPECT_EQ(lum.getNumIterationsDone(), 2);
}

// ---------------------------------------------------------------------------------------
// A 200-pose loop with odometry drift and one loop closure.
TEST_F(QuietPcl, LoopOf200PosesCloses)
{
  const int n = 200;
  const double radius = 30.0;
  Poses truth;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n;
    truth.push_back(makePose(radius * std::sin(a),
                             radius * (1.0 - std::cos(a)),
                             0.5 * std::sin(3 * a),
                             0.05 * std::sin(5 * a),
                             0.05 * std::cos(4 * a),
                             a));
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> pairs;
  for (int i = 0; i + 1 < n; ++i)
    pairs.emplace_back(i, i + 1);
  pairs.emplace_back(n - 1, 0); // the loop closure
  const SyntheticGraph sg = makeGraph(truth, pairs, 100, 2.0, 0.001, 51);

  // Odometry: true relative motions with 0.3 deg / 2 cm noise per step.
  std::mt19937 rng(52);
  Poses odo = {truth[0]};
  for (int i = 1; i < n; ++i) {
    const Eigen::Matrix4d rel = truth[i - 1].inverse() * truth[i];
    odo.push_back(odo.back() * perturb(rel, 0.3 * kDeg, 0.02, rng));
  }
  const Errors e0 = poseErrors(odo, truth);

  ParallelLUM<pcl::PointXYZ> lum;
  for (int v = 0; v < n; ++v)
    lum.addPointCloud(sg.clouds[v], Eigen::Matrix4f(odo[v].cast<float>()));
  for (const auto& [i, j, corrs] : sg.links)
    lum.setCorrespondences(i, j, corrs);
  lum.setMaxIterations(30);
  lum.setConvergenceThreshold(1e-9f);
  lum.compute();
  EXPECT_LT(lum.getNumIterationsDone(), 30); // converged (Gauss-Newton: a few steps)
  Poses got;
  for (int v = 0; v < n; ++v)
    got.push_back(lum.getPoseMatrix(v));
  const Errors e1 = poseErrors(got, truth);
  std::printf("loop: odometry max %.3f m %.2f deg -> %.5f m %.4f deg in %d iterations\n",
              e0.max_trans,
              e0.max_rot / kDeg,
              e1.max_trans,
              e1.max_rot / kDeg,
              lum.getNumIterationsDone());
  EXPECT_GT(e0.max_trans, 0.5); // the drift is real
  EXPECT_LT(e1.max_trans, e0.max_trans / 10.0);
  EXPECT_LT(e1.max_rot, e0.max_rot / 10.0);
  EXPECT_LT(e1.mean_trans, e0.mean_trans / 10.0);
  // Step 5's covariances: symmetric positive definite, and largest halfway round the loop,
  // farthest from the fixed vertex 0 along both branches.
  const pcl_parallel::lum::Matrix6d c1 = lum.getPoseCovariance(1);
  const pcl_parallel::lum::Matrix6d c100 = lum.getPoseCovariance(100);
  EXPECT_TRUE(c100.isApprox(c100.transpose()));
  EXPECT_EQ(c100.llt().info(), Eigen::Success); // positive definite
  const double var1 = c1.topLeftCorner(3, 3).trace();
  const double var100 = c100.topLeftCorner(3, 3).trace();
  EXPECT_GT(var100, 10.0 * var1);
  EXPECT_TRUE(lum.getPoseCovariance(0).isZero());
  // The closure itself: the last pose is where it should be relative to the first.
  const double t =
      pcl_parallel::poseError(got[0].inverse() * got[n - 1], truth[0].inverse() * truth[n - 1])
          .distance;
  EXPECT_LT(t, 0.01);
}

// ---------------------------------------------------------------------------------------
// Bad input.
TEST_F(QuietPcl, BadInputIsAClearError)
{
  const SyntheticGraph sg = smallGraph();
  auto make = [&]() {
    auto lum = std::make_unique<ParallelLUM<pcl::PointXYZ>>();
    for (std::size_t v = 0; v < sg.clouds.size(); ++v)
      lum->addPointCloud(sg.clouds[v], Eigen::Matrix4f(sg.truth[v].cast<float>()));
    return lum;
  };
  { // zero links
    auto lum = make();
    EXPECT_THROW(lum->compute(), std::invalid_argument);
  }
  { // link to a missing vertex
    auto lum = make();
    EXPECT_THROW(lum->addLink(0, 7), std::out_of_range);
    EXPECT_THROW(lum->setCorrespondences(7, 0, std::get<2>(sg.links[0])), std::out_of_range);
    EXPECT_THROW(lum->addLink(2, 2), std::invalid_argument);
  }
  { // empty cloud
    auto lum = make();
    for (const auto& [i, j, corrs] : sg.links)
      lum->setCorrespondences(i, j, corrs);
    lum->setPointCloud(3, Cloud::Ptr(new Cloud));
    EXPECT_THROW(lum->compute(), std::invalid_argument);
  }
  { // NaN pose
    auto lum = make();
    for (const auto& [i, j, corrs] : sg.links)
      lum->setCorrespondences(i, j, corrs);
    Eigen::Vector6f nan_pose = Eigen::Vector6f::Zero();
    nan_pose(4) = std::numeric_limits<float>::quiet_NaN();
    lum->setPose(2, nan_pose);
    EXPECT_THROW(lum->compute(), std::invalid_argument);
  }
  { // disconnected from vertex 0: only links among 1..4
    auto lum = make();
    lum->setCorrespondences(1, 2, std::get<2>(sg.links[1]));
    lum->setCorrespondences(2, 3, std::get<2>(sg.links[2]));
    lum->setCorrespondences(3, 4, std::get<2>(sg.links[3]));
    EXPECT_THROW(lum->compute(), std::invalid_argument);
  }
  { // correspondence index out of range
    auto lum = make();
    pcl::CorrespondencesPtr bad(new pcl::Correspondences(*std::get<2>(sg.links[0])));
    bad->emplace_back(0, 1000000, 0.0f);
    lum->setCorrespondences(0, 1, bad);
    EXPECT_THROW(lum->compute(), std::out_of_range);
  }
  { // fixed mode without correspondences on a link
    auto lum = make();
    lum->addLink(0, 1);
    lum->getLoopGraph()
        ->
        operator[](boost::edge(0, 1, *lum->getLoopGraph()).first)
        .corrs_.reset();
    EXPECT_THROW(lum->compute(), std::invalid_argument);
  }
}

// A redundant link with too few pairs, or degenerate (collinear) pairs, is dropped with a
// warning; the others still solve and no pose becomes NaN.
TEST_F(QuietPcl, DegenerateLinkIsDroppedNotNaN)
{
  const SyntheticGraph sg = smallGraph();
  const Poses start = perturbAll(sg.truth, 2.0 * kDeg, 0.003, 61);
  ParallelLUM<pcl::PointXYZ> lum;
  for (std::size_t v = 0; v < sg.clouds.size(); ++v)
    lum.addPointCloud(sg.clouds[v], Eigen::Matrix4f(start[v].cast<float>()));
  for (const auto& [i, j, corrs] : sg.links)
    if (!(i == 1 && j == 3))
      lum.setCorrespondences(i, j, corrs);
  pcl::CorrespondencesPtr few(new pcl::Correspondences(std::get<2>(sg.links[5])->begin(),
                                                       std::get<2>(sg.links[5])->begin() + 2));
  lum.setCorrespondences(1, 3, few);
  // Link 0 -> 2 of pairs that all sit on one point: rotation about it is unobservable.
  pcl::CorrespondencesPtr collinear(new pcl::Correspondences);
  for (int k = 0; k < 50; ++k)
    collinear->emplace_back(0, 0, 0.0f);
  lum.setCorrespondences(0, 2, collinear);
  lum.setMaxIterations(5);
  lum.compute();
  EXPECT_EQ(lum.getNumDroppedLinks(), 2u);
  Poses got;
  for (std::size_t v = 0; v < sg.clouds.size(); ++v) {
    got.push_back(lum.getPoseMatrix(v));
    EXPECT_TRUE(got.back().allFinite());
  }
  EXPECT_LT(poseErrors(got, sg.truth).max_rot, 0.05 * kDeg);
}

// ---------------------------------------------------------------------------------------
// Stanford bunny (real data): pLUM from ground truth perturbed by 2 deg / 3 mm.
struct Bunny {
  std::vector<std::string> names;
  std::vector<Cloud::Ptr> clouds;
  Poses truth;
};

/** Every `step`-th point of each scan (deterministic subsampling to keep the test fast). */
Bunny
loadBunny(const std::string& conf, int step)
{
  Bunny b;
  const auto dir = std::filesystem::path(conf).parent_path();
  for (const auto& e : pcl_parallel::io::loadStanfordConf(conf)) {
    const Cloud::Ptr full = pcl_parallel::io::loadStanfordScan((dir / e.file).string());
    Cloud::Ptr sub(new Cloud);
    for (std::size_t k = 0; k < full->size(); k += static_cast<std::size_t>(step))
      sub->push_back((*full)[k]);
    b.names.push_back(e.file);
    b.clouds.push_back(sub);
    b.truth.push_back(e.pose);
  }
  return b;
}

/** The bunny graph of the issue: all scans at the start poses (bun.conf perturbed), links
 *  between scans that overlap by >= kBunnyLinkOverlap (the smaller of the two directions'
 *  fractions of points with a neighbour within kBunnyLinkDistance), measured at the start
 *  poses, as a user must (issue 11: links chosen at ground truth told the test the
 *  answer's topology). */
constexpr double kBunnyLinkDistance = 0.01, kBunnyLinkOverlap = 0.30;
// Start errors (2 deg / 3 mm) drawn with one seed per test; `pcl_parallel_bench lum-seeds`
// runs both modes from each of these seeds, so a pass is not one lucky draw.
constexpr std::uint32_t kBunnySeeds[] = {2007, 11, 23};
// The sanitizer stages look for memory errors and races, not accuracy, and run ten times
// slower: the two convergence tests below (100 s for one seed under ASan) are left to the
// release stage; their code paths (both pairing modes, link steps, the gate) run there in
// BunnyPlumIsIdenticalForOneAndTwoThreads.
#define PCL_PARALLEL_SKIP_ACCURACY_UNDER_SANITIZERS()                                          \
  if (pcl_parallel::test::kSanitized)                                                          \
  GTEST_SKIP() << "accuracy test, run by the release stage (scripts/test.sh release)"
constexpr std::size_t kBunnyMinLinks = 20;
void
setUpBunny(const Bunny& b, ParallelLUM<pcl::PointXYZ>& lum, const Poses& start)
{
  for (std::size_t v = 0; v < b.clouds.size(); ++v)
    lum.addPointCloud(b.clouds[v], Eigen::Matrix4f::Identity());
  for (std::size_t v = 0; v < b.clouds.size(); ++v)
    lum.setPoseMatrix(v, start[v]);
  for (const auto& [i, j] : lum.findOverlappingPairs(kBunnyLinkDistance, kBunnyLinkOverlap))
    lum.addLink(i, j);
  // Queries: every 4th point (the trees keep all), both directions per link.
  lum.setQueryStep(4);
  lum.setMaxIterations(1);
}

/** Max/mean errors vs bun.conf after every iteration of compute() (index 0: the start). */
std::vector<Errors>
relaxBunny(const Bunny& b, ParallelLUM<pcl::PointXYZ>& lum)
{
  std::vector<Errors> trace;
  auto record = [&](int, double) {
    Poses got;
    for (std::size_t v = 0; v < b.clouds.size(); ++v)
      got.push_back(lum.getPoseMatrix(v));
    trace.push_back(poseErrors(got, b.truth));
    const Errors& e = trace.back();
    if (trace.size() <= 10 || trace.size() % 10 == 1)
      std::printf("it %2zu: rot max %.3f mean %.3f deg, trans max %.3f mean %.3f mm\n",
                  trace.size() - 1,
                  e.max_rot / kDeg,
                  e.mean_rot / kDeg,
                  e.max_trans * 1e3,
                  e.mean_trans * 1e3);
  };
  record(-1, 0.0);
  lum.setIterationCallback(record);
  lum.compute();
  return trace;
}

void
expectBunnyTargets(const Errors& e, const Errors& start)
{
  EXPECT_LT(e.max_rot, 1.0 * kDeg);
  EXPECT_LT(e.max_trans, 2e-3);
  EXPECT_LT(e.mean_rot, 0.5 * kDeg);
  EXPECT_LT(e.max_rot, start.max_rot);
}

// The bunny case with the options that make the relaxation monotone:
// point-to-plane pairs, each link aligned by up to 5 pairing steps per iteration, gate
// 5 mm -> 2 mm (x0.7 per iteration, the largest start error being ~6 mm per point).
TEST_F(QuietPcl, BunnyPlumConvergesToGroundTruth)
{
  PCL_PARALLEL_SKIP_ACCURACY_UNDER_SANITIZERS();
  PCL_PARALLEL_REQUIRE_DATA(conf, "stanford_bunny/bun.conf");
  const Bunny b = loadBunny(conf, 1);
  ASSERT_EQ(b.clouds.size(), 10u);
  ASSERT_EQ(b.names[0], "bun000.ply");
  {
    // bun.conf's direction (R(q)^T): at ground truth bun045 lies on bun000.
    ParallelLUM<pcl::PointXYZ> lum;
    setUpBunny(b, lum, b.truth);
    EXPECT_GT(lum.computeOverlap(1, 0, 0.002), 0.8);
  }
  for (const std::uint32_t seed : {kBunnySeeds[2]}) { // the seed that settles in a 2-cycle
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Poses start = perturbAll(b.truth, 2.0 * kDeg, 0.003, seed);
    ParallelLUM<pcl::PointXYZ> lum;
    setUpBunny(b, lum, start);
    EXPECT_GE(boost::num_edges(*lum.getLoopGraph()), kBunnyMinLinks);
    lum.setPointToPlane(true);
    lum.setLinkIterations(5);
    lum.setCorrespondenceDistanceSchedule(0.005, 0.002, 0.7);
    lum.setMaxIterations(20);
    lum.setConvergenceThreshold(1e-6f); // mean update 1 um / 1 urad
    const std::vector<Errors> trace = relaxBunny(b, lum);
    ASSERT_GE(trace.size(), 5u);
    // Settled: with links chosen at the start poses, seed 23 ends in a 2-cycle of re-paired
    // points (max error alternating 0.305/0.306 deg, 0.693 mm: measured) that never meets
    // the 1 um threshold, so the test asserts that the error stopped moving instead.
    for (std::size_t k = trace.size() - 3; k < trace.size(); ++k) {
      EXPECT_NEAR(trace[k].max_rot, trace.back().max_rot, 0.005 * kDeg) << "iteration " << k;
      EXPECT_NEAR(trace[k].max_trans, trace.back().max_trans, 5e-6) << "iteration " << k;
    }
    // The mean error must not grow. Once converged (from iteration ~3), the fixed point
    // still moves by 0.002 deg / 0.001 mm (measured) as the gate reaches 2 mm, so growth
    // below 0.01 deg / 0.01 mm, 100x below the targets, is allowed. A least-squares step
    // may move one pose away while it pulls the others in (seed 23 built with clang 14:
    // max translation error 3.000 -> 3.058 mm at iteration 1 while the mean halves), so
    // the maximum is only bounded by the start plus 5%; the paper's mode, whose maximum
    // doubles on the way (see below), fails that bound.
    for (std::size_t k = 1; k < trace.size(); ++k) {
      EXPECT_LE(trace[k].mean_rot, trace[k - 1].mean_rot + 0.01 * kDeg) << "iteration " << k;
      EXPECT_LE(trace[k].mean_trans, trace[k - 1].mean_trans + 1e-5) << "iteration " << k;
      EXPECT_LE(trace[k].max_rot, 1.05 * trace.front().max_rot) << "iteration " << k;
      EXPECT_LE(trace[k].max_trans, 1.05 * trace.front().max_trans) << "iteration " << k;
    }
    expectBunnyTargets(trace.back(), trace.front());
  }
}

// The paper's pLUM (point-to-point, one pairing per link and iteration) on the same case,
// gate 10 mm -> 2 mm (x0.9). It reaches the targets too, but first trades rotation for
// translation error: the maximum rises to ~4.3 deg around iteration 5 (measured; as
// pcl::IterativeClosestPoint on a single pair, see TwoScanPlumFollowsPclIcp), because
// one closest-point step sees only part of a pair's misalignment. From iteration 20 the
// maximum error must not grow by more than the jitter of re-paired points (sub-
// micrometre once converged; 0.2 um measured between iterations 46-48 with clang).
TEST_F(QuietPcl, BunnyPaperPlumConvergesToGroundTruth)
{
  PCL_PARALLEL_SKIP_ACCURACY_UNDER_SANITIZERS();
  PCL_PARALLEL_REQUIRE_DATA(conf, "stanford_bunny/bun.conf");
  const Bunny b = loadBunny(conf, 1);
  for (const std::uint32_t seed : {kBunnySeeds[0]}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    const Poses start = perturbAll(b.truth, 2.0 * kDeg, 0.003, seed);
    ParallelLUM<pcl::PointXYZ> lum;
    setUpBunny(b, lum, start);
    lum.setCorrespondenceDistanceSchedule(0.01, 0.002, 0.9);
    lum.setMaxIterations(50);
    const std::vector<Errors> trace = relaxBunny(b, lum);
    ASSERT_EQ(trace.size(), 51u);
    for (std::size_t k = 21; k < trace.size(); ++k) {
      EXPECT_LE(trace[k].max_rot, trace[k - 1].max_rot + 1e-5) << "iteration " << k;
      EXPECT_LE(trace[k].max_trans, trace[k - 1].max_trans + 1e-6) << "iteration " << k;
    }
    expectBunnyTargets(trace.back(), trace.front());
  }
}

TEST_F(QuietPcl, BunnyPlumIsIdenticalForOneAndTwoThreads)
{
  PCL_PARALLEL_REQUIRE_DATA(conf, "stanford_bunny/bun.conf");
  // Under a sanitizer every 4th point: still two reduction blocks of queries per link.
  const Bunny b = loadBunny(conf, pcl_parallel::test::kSanitized ? 4 : 2);
  const Poses start = perturbAll(b.truth, 2.0 * kDeg, 0.003, 2007);
  for (bool options : {false, true}) { // the paper's pLUM; point-to-plane, link steps
    Poses result[2];
    for (unsigned threads : {1u, 2u}) {
      ParallelLUM<pcl::PointXYZ> lum;
      lum.setNumberOfThreads(threads);
      setUpBunny(b, lum, start);
      lum.setCorrespondenceDistance(0.01);
      lum.setPointToPlane(options);
      lum.setLinkIterations(options ? 3 : 1);
      lum.setMaxIterations(3);
      lum.compute();
      for (std::size_t v = 0; v < b.clouds.size(); ++v)
        result[threads - 1].push_back(lum.getPoseMatrix(v));
    }
    for (std::size_t v = 0; v < b.clouds.size(); ++v)
      EXPECT_EQ(result[0][v], result[1][v]) << "options " << options << ", vertex " << v;
  }
}

// With two scans pLUM is point-to-point ICP: one iteration = closest points + the
// least-squares pose. Its trajectory follows pcl::IterativeClosestPoint's from the same
// start with the same pairs (source points every 4th, one direction, 2 mm gate).
TEST_F(QuietPcl, TwoScanPlumFollowsPclIcp)
{
  PCL_PARALLEL_REQUIRE_DATA(conf, "stanford_bunny/bun.conf");
  const Bunny b = loadBunny(conf, 1);
  std::mt19937 rng(5);
  const Eigen::Matrix4d start = perturb(b.truth[1], 2.0 * kDeg, 0.003, rng);
  const int iterations = 30;

  ParallelLUM<pcl::PointXYZ> lum;
  lum.addPointCloud(b.clouds[0], Eigen::Matrix4f(b.truth[0].cast<float>()));
  lum.addPointCloud(b.clouds[1], Eigen::Matrix4f(start.cast<float>()));
  lum.addLink(1, 0);
  lum.setCorrespondenceDistance(0.002);
  lum.setQueryStep(4);
  lum.setSymmetricCorrespondences(false);
  lum.setMaxIterations(iterations);
  lum.compute();

  Cloud::Ptr src(new Cloud), tgt(new Cloud);
  for (std::size_t k = 0; k < b.clouds[1]->size(); k += 4)
    src->push_back((*b.clouds[1])[k]);
  pcl::transformPointCloud(*b.clouds[0], *tgt, b.truth[0].cast<float>());
  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
  icp.setInputSource(src);
  icp.setInputTarget(tgt);
  icp.setMaxCorrespondenceDistance(0.002);
  icp.setMaximumIterations(iterations);
  icp.setTransformationEpsilon(0);
  icp.setEuclideanFitnessEpsilon(0);
  Cloud aligned;
  icp.align(aligned, start.cast<float>());

  const auto [r, t] = pcl_parallel::poseError(lum.getPoseMatrix(1),
                                              icp.getFinalTransformation().cast<double>());
  const auto [r0, t0] = pcl_parallel::poseError(start, b.truth[1]);
  std::printf(
      "pLUM vs PCL ICP after %d iterations: %.4f deg %.4f mm\n", iterations, r / kDeg, t * 1e3);
  EXPECT_LT(r, 0.05 * r0);
  EXPECT_LT(t, 0.05 * t0);
}

// Link iterations: one iteration with k pairing steps per link aligns a two-scan graph as
// k iterations of one step do (the measurement is the pairwise motion plus the last
// step). With the fixed vertex as the link's source the motion found for it is applied,
// negated, to the other vertex: equal to first order, so the two differ by a second-order
// term (|w|^2 times the scans' distance, here 0.1 mm after a 2 deg step) that the next
// iteration removes.
TEST_F(QuietPcl, LinkIterationsMatchOuterIterations)
{
  PCL_PARALLEL_REQUIRE_DATA(conf, "stanford_bunny/bun.conf");
  const Bunny b = loadBunny(conf, 2);
  std::mt19937 rng(6);
  const Eigen::Matrix4d start = perturb(b.truth[1], 2.0 * kDeg, 0.003, rng);
  auto run = [&](int outer, int inner, bool reversed) {
    ParallelLUM<pcl::PointXYZ> lum;
    lum.addPointCloud(b.clouds[0], Eigen::Matrix4f(b.truth[0].cast<float>()));
    lum.addPointCloud(b.clouds[1], Eigen::Matrix4f(start.cast<float>()));
    if (reversed)
      lum.addLink(0, 1);
    else
      lum.addLink(1, 0);
    lum.setCorrespondenceDistance(0.005);
    lum.setPointToPlane(true);
    lum.setMaxIterations(outer);
    lum.setLinkIterations(inner);
    lum.compute();
    return lum.getPoseMatrix(1);
  };
  const Eigen::Matrix4d ten_outer = run(10, 1, false);
  const auto [r0, t0] = pcl_parallel::poseError(start, ten_outer);
  pcl_parallel::PoseError e = pcl_parallel::poseError(run(1, 10, false), ten_outer);
  std::printf("start %.3f deg %.3f mm; 1 x 10 steps: %.2e deg %.2e mm apart\n",
              r0 / kDeg,
              t0 * 1e3,
              e.angle / kDeg,
              e.distance * 1e3);
  EXPECT_LT(e.angle, 1e-4 * r0);
  EXPECT_LT(e.distance, 1e-4 * t0);
  e = pcl_parallel::poseError(run(1, 10, true), ten_outer);
  std::printf("reversed link, 1 x 10 steps: %.2e deg %.2e mm apart\n",
              e.angle / kDeg,
              e.distance * 1e3);
  EXPECT_LT(e.angle, 1e-4 * r0);
  EXPECT_LT(e.distance, 0.05 * t0);
  e = pcl_parallel::poseError(run(2, 10, true), run(11, 1, false));
  std::printf("reversed link, 2 x 10 steps: %.2e deg %.2e mm apart\n",
              e.angle / kDeg,
              e.distance * 1e3);
  EXPECT_LT(e.angle, 1e-4 * r0);
  EXPECT_LT(e.distance, 1e-4 * t0);
}

} // namespace

// Pose constraints alone (no scan links) hold each vertex where its constraint puts it: the
// chain of the measured relative poses, far from the origin and from a start 3 degrees
// and 5 cm off, to rounding.
TEST_F(QuietPcl, PoseConstraintsAloneGiveTheirChain)
{
  const Poses truth = {makePose(1000.0, -500.0, 20.0, 0.1, -0.05, 1.0),
                       makePose(1002.0, -499.0, 20.1, 0.12, -0.02, 1.3),
                       makePose(1003.5, -496.0, 20.0, 0.08, -0.06, 1.9),
                       makePose(1003.0, -494.0, 19.8, 0.1, 0.0, 2.6)};
  const Poses start = perturbAll(truth, 3.0 * kDeg, 0.05, 71);
  ParallelLUM<pcl::PointXYZ> lum;
  Cloud::Ptr few(new Cloud);
  few->push_back(pcl::PointXYZ(1.0f, 2.0f, 3.0f));
  for (const auto& p : start)
    lum.setPoseMatrix(lum.addPointCloud(few, Eigen::Matrix4f::Identity()), p);
  pcl_parallel::lum::Matrix6d info = pcl_parallel::lum::Matrix6d::Identity();
  info.bottomRightCorner<3, 3>() *= 100.0; // any positive definite weight
  for (std::size_t v = 1; v < truth.size(); ++v)
    lum.addPoseConstraint(v, v - 1, truth[v - 1].inverse() * truth[v], info);
  EXPECT_EQ(lum.getNumPoseConstraints(), 3u);
  lum.setCorrespondenceDistance(0.1);
  lum.setMaxIterations(10);
  lum.compute();
  for (std::size_t v = 1; v < truth.size(); ++v) {
    const auto [angle, dist] = pcl_parallel::poseError(lum.getPoseMatrix(v), truth[v]);
    EXPECT_LT(angle, 1e-9) << v;
    EXPECT_LT(dist, 1e-8) << v;
  }
}

// The information is in the source's frame: two constraints that differ only in
// translation, each sure along another body axis of a source turned 90 degrees, meet
// where sum R I_k R^T (t - t_k) = 0.
TEST_F(QuietPcl, PoseConstraintInformationIsInTheSourceFrame)
{
  ParallelLUM<pcl::PointXYZ> lum;
  Cloud::Ptr few(new Cloud);
  few->push_back(pcl::PointXYZ(1.0f, 2.0f, 3.0f));
  lum.addPointCloud(few);
  lum.addPointCloud(few);
  const Eigen::Matrix3d r = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).matrix();
  const Eigen::Vector3d ta(1.0, 0.0, 0.0), tb(0.0, 1.0, 0.5);
  Eigen::Matrix4d za = Eigen::Matrix4d::Identity(), zb = za;
  za.topLeftCorner<3, 3>() = zb.topLeftCorner<3, 3>() = r;
  za.topRightCorner<3, 1>() = ta;
  zb.topRightCorner<3, 1>() = tb;
  pcl_parallel::lum::Matrix6d ia = pcl_parallel::lum::Matrix6d::Identity() * 1e4, ib = ia;
  ia.topLeftCorner<3, 3>() = Eigen::Vector3d(100.0, 1.0, 2.0).asDiagonal();
  ib.topLeftCorner<3, 3>() = Eigen::Vector3d(1.0, 100.0, 3.0).asDiagonal();
  lum.setPoseMatrix(1, za);
  lum.addPoseConstraint(1, 0, za, ia);
  lum.addPoseConstraint(1, 0, zb, ib);
  lum.setCorrespondenceDistance(0.1);
  lum.setMaxIterations(5);
  lum.compute();
  const Eigen::Matrix3d wa = r * ia.topLeftCorner<3, 3>() * r.transpose();
  const Eigen::Matrix3d wb = r * ib.topLeftCorner<3, 3>() * r.transpose();
  const Eigen::Vector3d expected = (wa + wb).ldlt().solve(wa * ta + wb * tb);
  const Eigen::Matrix4d got = lum.getPoseMatrix(1);
  EXPECT_LT((got.topRightCorner<3, 1>() - expected).norm(), 1e-9);
  EXPECT_LT((got.topLeftCorner<3, 3>() - r).norm(), 1e-9);

  EXPECT_THROW(lum.addPoseConstraint(1, 1, za, ia), std::invalid_argument);
  EXPECT_THROW(lum.addPoseConstraint(2, 0, za, ia), std::out_of_range);
  pcl_parallel::lum::Matrix6d bad = ia;
  bad(0, 1) = 5.0; // not symmetric
  EXPECT_THROW(lum.addPoseConstraint(1, 0, za, bad), std::invalid_argument);
  bad = ia;
  bad(2, 2) = std::nan("");
  EXPECT_THROW(lum.addPoseConstraint(1, 0, za, bad), std::invalid_argument);
  EXPECT_THROW(lum.addPoseConstraint(1, 0, za, ia, -1.0), std::invalid_argument);
  // A new graph drops the constraints on the old one's vertices.
  EXPECT_EQ(lum.getNumPoseConstraints(), 2u);
  lum.setLoopGraph(
      ParallelLUM<pcl::PointXYZ>::SLAMGraphPtr(new ParallelLUM<pcl::PointXYZ>::SLAMGraph));
  EXPECT_EQ(lum.getNumPoseConstraints(), 0u);
}

// A constraint the others contradict (a triangle of right ones, one wrong by 10 cm on the
// same pair, 100 sigma): plain least squares meets it partway; under a Cauchy kernel it yields.
// Right constraints alone end where they are either way. getPoseConstraintChi2 tells the
// wrong one from the right ones.
TEST_F(QuietPcl, ContradictedPoseConstraintYieldsUnderCauchy)
{
  const Poses truth = {makePose(0, 0, 0, 0, 0, 0),
                       makePose(1.0, 0.1, 0, 0.02, 0.04, 0.3),
                       makePose(1.5, 1.0, 0.1, 0.0, -0.05, 1.0)};
  std::vector<double> chi2;
  auto run = [&](bool with_wrong, double scale) {
    ParallelLUM<pcl::PointXYZ> lum;
    Cloud::Ptr few(new Cloud);
    few->push_back(pcl::PointXYZ(1.0f, 2.0f, 3.0f));
    for (std::size_t v = 0; v < truth.size(); ++v)
      lum.addPointCloud(few, Eigen::Matrix4f(truth[v].cast<float>()));
    const pcl_parallel::lum::Matrix6d info = pcl_parallel::lum::Matrix6d::Identity() * 1e6;
    for (const auto& e : {std::make_pair(1, 0), std::make_pair(2, 1), std::make_pair(2, 0)})
      lum.addPoseConstraint(
          e.first, e.second, truth[e.second].inverse() * truth[e.first], info, scale);
    Eigen::Matrix4d wrong = truth[1].inverse() * truth[2];
    wrong(0, 3) += 0.1;
    if (with_wrong)
      lum.addPoseConstraint(2, 1, wrong, info, scale);
    lum.setCorrespondenceDistance(0.1);
    lum.setMaxIterations(20);
    lum.compute();
    chi2.clear();
    for (std::size_t k = 0; k < lum.getNumPoseConstraints(); ++k)
      chi2.push_back(lum.getPoseConstraintChi2(k));
    EXPECT_THROW(lum.getPoseConstraintChi2(lum.getNumPoseConstraints()), std::out_of_range);
    return pcl_parallel::poseError(lum.getPoseMatrix(2), truth[2]).distance;
  };
  const double plain = run(true, 0.0), cauchy = run(true, 16.8);
  ASSERT_EQ(chi2.size(), 4u);
  EXPECT_GT(chi2[3], 0.9e4); // (0.1 m / 1 mm)^2 = 1e4: nearly all of it is left
  for (int k = 0; k < 3; ++k)
    EXPECT_LT(chi2[k], 16.8) << k;
  EXPECT_GT(plain, 0.015); // a third of the 10 cm, shared with the two others
  EXPECT_LT(cauchy, 0.1 * plain);
  EXPECT_LT(run(false, 16.8), 1e-9);
  EXPECT_LT(run(false, 0.0), 1e-9);
}
