/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <deque>

namespace pcl_parallel {
namespace registration {

/**
 * \brief KISS-ICP's adaptive correspondence threshold (Vizzo et al., "KISS-ICP: In Defense
 * of Point-to-Point ICP", RA-L 2023, Sec. III-C; kiss-icp core/Threshold.cpp).
 *
 * After each registration the front end reports the model deviation ΔT = T_pred⁻¹ T_icp,
 * the motion the prediction (odometry step or constant velocity) missed. Its size as a
 * point displacement at \a max_range is δ = |Δt| + 2 r_max sin(θ/2) (Sec. III-C). Deviations
 * above \a min_motion are kept; σ = sqrt(mean δ²), seeded with the initial threshold as one
 * sample, is the spread the next registration must admit. KISS-ICP then matches within
 * 3σ and weights residuals with a Geman-McClure kernel of scale σ/3.
 *
 * \a window > 0 keeps only the last \a window samples (the initial one included while it
 * is among them), so the threshold also shrinks back after a sudden motion; 0 (default)
 * is KISS-ICP's running mean over all samples.
 */
/** How far a relative motion moves points at distance `range` from the sensor:
 *  translation plus the chord the rotation sweeps (KISS-ICP's model error, Vizzo et al.
 *  2023, Sec. III-C). */
double
motionDisplacement(const Eigen::Matrix4d& motion, double range);

/** KISS-ICP's adaptive correspondence gate: 3σ of how far matches moved scans from the
 *  prediction (Vizzo et al., RA-L 2023, Sec. III-C). */
class AdaptiveThreshold {
public:
  /** A gate starting at \a initial_threshold; deviations below \a min_motion are not sampled,
   *  rotations count at \a max_range; \a window > 0 keeps only the last samples. */
  AdaptiveThreshold(double initial_threshold,
                    double min_motion,
                    double max_range,
                    std::size_t window = 0);

  /** Adds the deviation between the predicted and the registered motion (4x4 rigid). */
  void
  updateModelDeviation(const Eigen::Matrix4d& deviation);

  /** δ of a deviation: translation plus the chord the rotation moves a point at max range
   * along. */
  double
  modelError(const Eigen::Matrix4d& deviation) const;

  /** σ: the RMS of the kept model errors. */
  double
  sigma() const;

  /** The correspondence distance KISS-ICP uses: 3σ. */
  double
  correspondenceDistance() const
  {
    return 3.0 * sigma();
  }

  /** The Geman-McClure kernel scale KISS-ICP uses: σ/3. */
  double
  kernelScale() const
  {
    return sigma() / 3.0;
  }

  /** Deviations at or below this are not counted. */
  double
  minMotion() const
  {
    return min_motion_;
  }
  /** The range at which a rotation counts as a displacement. */
  double
  maxRange() const
  {
    return max_range_;
  }

  /** The kept samples, the initial threshold's included. */
  std::size_t
  numSamples() const
  {
    return samples_.size();
  }

  /** The kept deviations: numSamples() less the initial threshold's while it is kept. */
  std::size_t
  numDeviations() const
  {
    return samples_.size() - (seeded_ ? 1 : 0);
  }

  /** The kept deviations' translation |Δt| and rotation angle θ (rad), each as an RMS on
   *  its own (the initial threshold not counted); 0 before the first deviation. δ
   *  weighs a rotation by max range; these tell the two apart, e.g. for the spread of a
   *  prior (docs/design.md, "The motion prior's spread"). */
  double
  translationSigma() const;
  /** The RMS rotation of the sampled deviations (rad). */
  double
  rotationSigma() const;

private:
  struct Sample {
    double error2, translation2, rotation2; ///< δ², |Δt|², θ²
    Sample&
    operator+=(const Sample& s)
    {
      error2 += s.error2;
      translation2 += s.translation2;
      rotation2 += s.rotation2;
      return *this;
    }
  };
  void
  resum();

  double min_motion_;
  double max_range_;
  std::size_t window_;
  std::deque<Sample> samples_; ///< kept samples, oldest first
  bool seeded_ = true;         ///< the initial threshold is still samples_.front()
  Sample sum_{0.0, 0.0, 0.0};  ///< Σ samples_ (recomputed on eviction: no drift)
};

} // namespace registration
} // namespace pcl_parallel
