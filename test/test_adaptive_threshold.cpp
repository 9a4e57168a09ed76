/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * AdaptiveThreshold (KISS-ICP Sec. III-C) against hand-computed values and on a sudden
 * motion.
 */
#include <pcl_parallel/registration/adaptive_threshold.h>

#include <Eigen/Geometry>

#include <cmath>
#include <gtest/gtest.h>
#include <stdexcept>

namespace {

using pcl_parallel::registration::AdaptiveThreshold;

Eigen::Matrix4d
deviation(double tx, double angle)
{
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  m(0, 3) = tx;
  return m;
}

// δ = |Δt| + 2 r_max sin(θ/2); σ = sqrt(mean δ²) with the initial threshold as the first
// sample; deviations at or below min_motion are not counted.
TEST(AdaptiveThreshold, HandComputedValues)
{
  AdaptiveThreshold th(2.0, 0.1, 100.0);
  EXPECT_DOUBLE_EQ(th.sigma(), 2.0);
  EXPECT_NEAR(th.modelError(deviation(0.3, 0.0)), 0.3, 1e-12);
  EXPECT_NEAR(th.modelError(deviation(0.0, 0.01)), 200.0 * std::sin(0.005), 1e-9);
  EXPECT_NEAR(th.modelError(deviation(0.2, -0.02)), 0.2 + 200.0 * std::sin(0.01), 1e-9);
  th.updateModelDeviation(deviation(0.05, 0.0)); // below min motion
  EXPECT_EQ(th.numSamples(), 1u);
  EXPECT_DOUBLE_EQ(th.sigma(), 2.0);
  th.updateModelDeviation(deviation(1.0, 0.0));
  th.updateModelDeviation(deviation(0.5, 0.0));
  EXPECT_NEAR(th.sigma(), std::sqrt((4.0 + 1.0 + 0.25) / 3.0), 1e-12);
  EXPECT_NEAR(th.correspondenceDistance(), 3.0 * th.sigma(), 1e-15);
  EXPECT_NEAR(th.kernelScale(), th.sigma() / 3.0, 1e-15);
}

// A sudden motion the prediction missed: before it, 3σ would reject it; after one
// sample of it, 3σ admits it; with a window the threshold returns exactly to the steady
// level once the jump leaves the window, and without one (KISS-ICP) it decays every frame.
TEST(AdaptiveThreshold, GrowsOnSuddenMotionAndShrinksBack)
{
  const double steady = 0.02, jump = 0.15;
  for (const std::size_t window : {std::size_t(10), std::size_t(0)}) {
    AdaptiveThreshold th(0.02, 0.001, 50.0, window);
    for (int k = 0; k < 30; ++k)
      th.updateModelDeviation(deviation(steady, 0.0));
    const double before = th.correspondenceDistance();
    EXPECT_NEAR(th.sigma(), steady, 1e-12);
    EXPECT_LT(before, jump) << "window " << window;
    th.updateModelDeviation(deviation(jump, 0.0));
    if (window > 0) {
      EXPECT_GE(th.correspondenceDistance(), jump);
    }
    else {
      EXPECT_GT(th.correspondenceDistance(), 1.2 * before);
    }
    // Steady frames again: with a window σ holds until the jump leaves it, then returns
    // exactly to the steady level; KISS-ICP's running mean decays every frame.
    const double peak = th.sigma();
    double last = peak;
    for (std::size_t k = 1; k <= 10; ++k) {
      th.updateModelDeviation(deviation(steady, 0.0));
      if (window == 0) {
        EXPECT_LT(th.sigma(), last) << "frame " << k;
      }
      else if (k < window) {
        EXPECT_DOUBLE_EQ(th.sigma(), peak) << "frame " << k;
      }
      last = th.sigma();
    }
    if (window > 0) {
      EXPECT_NEAR(th.sigma(), steady, 1e-12);
    }
    else { // 41 steady samples and the jump
      EXPECT_NEAR(th.sigma(), std::sqrt((41 * steady * steady + jump * jump) / 42), 1e-12);
    }
  }
  // A rotation counts as the displacement it causes at max range.
  AdaptiveThreshold rot(0.02, 0.001, 50.0, 1);
  rot.updateModelDeviation(deviation(0.0, 0.004));
  EXPECT_NEAR(rot.sigma(), 100.0 * std::sin(0.002), 1e-12);
}

// Translation and rotation each as an RMS of their own, without the initial threshold;
// a deviation below min motion counts in neither; a window evicts the seed, then samples.
TEST(AdaptiveThreshold, TranslationAndRotationSpreadsOfTheirOwn)
{
  AdaptiveThreshold th(2.0, 0.1, 100.0, 3);
  EXPECT_EQ(th.numDeviations(), 0u);
  EXPECT_EQ(th.translationSigma(), 0.0);
  EXPECT_EQ(th.rotationSigma(), 0.0);
  th.updateModelDeviation(deviation(0.05, 0.0)); // below min motion
  EXPECT_EQ(th.numDeviations(), 0u);
  th.updateModelDeviation(deviation(0.3, 0.0));
  th.updateModelDeviation(deviation(0.0, 0.004)); // 0.4 m at 100 m: counted
  EXPECT_EQ(th.numSamples(), 3u);
  EXPECT_EQ(th.numDeviations(), 2u);
  EXPECT_NEAR(th.translationSigma(), std::sqrt(0.09 / 2.0), 1e-12);
  EXPECT_NEAR(th.rotationSigma(), std::sqrt(0.004 * 0.004 / 2.0), 1e-12);
  // The combined sigma still has the seed and weighs the rotation at max range.
  const double chord = 200.0 * std::sin(0.002);
  EXPECT_NEAR(th.sigma(), std::sqrt((4.0 + 0.09 + chord * chord) / 3.0), 1e-12);
  th.updateModelDeviation(deviation(0.2, -0.002)); // the seed leaves the window
  EXPECT_EQ(th.numSamples(), 3u);
  EXPECT_EQ(th.numDeviations(), 3u);
  EXPECT_NEAR(th.translationSigma(), std::sqrt((0.09 + 0.04) / 3.0), 1e-12);
  EXPECT_NEAR(th.rotationSigma(), std::sqrt((0.004 * 0.004 + 0.002 * 0.002) / 3.0), 1e-12);
  th.updateModelDeviation(deviation(0.5, 0.0)); // the first sample leaves
  EXPECT_NEAR(th.translationSigma(), std::sqrt((0.04 + 0.25) / 3.0), 1e-12);
  EXPECT_NEAR(th.rotationSigma(), std::sqrt((0.004 * 0.004 + 0.002 * 0.002) / 3.0), 1e-12);
}

TEST(AdaptiveThreshold, BadArgumentsThrow)
{
  EXPECT_THROW(AdaptiveThreshold(0.0, 0.1, 100.0), std::invalid_argument);
  EXPECT_THROW(AdaptiveThreshold(2.0, -0.1, 100.0), std::invalid_argument);
  EXPECT_THROW(AdaptiveThreshold(2.0, 0.1, 0.0), std::invalid_argument);
  EXPECT_THROW(AdaptiveThreshold(std::nan(""), 0.1, 100.0), std::invalid_argument);
  AdaptiveThreshold th(2.0, 0.1, 100.0);
  Eigen::Matrix4d bad = Eigen::Matrix4d::Identity();
  bad(0, 3) = std::nan("");
  EXPECT_THROW(th.updateModelDeviation(bad), std::invalid_argument);
}

} // namespace
