/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/registration/adaptive_threshold.h>

#include <Eigen/Geometry>

#include <cmath>
#include <stdexcept>
#include <string>

namespace pcl_parallel {
namespace registration {

AdaptiveThreshold::AdaptiveThreshold(double initial_threshold,
                                     double min_motion,
                                     double max_range,
                                     std::size_t window)
    : min_motion_(min_motion)
    , max_range_(max_range)
    , window_(window)
{
  if (!(initial_threshold > 0.0) || !std::isfinite(initial_threshold) || !(min_motion >= 0.0) ||
      !(max_range > 0.0) || !std::isfinite(max_range))
    throw std::invalid_argument(
        "AdaptiveThreshold: initial threshold and max range must be positive and finite, "
        "min motion >= 0 (got " +
        std::to_string(initial_threshold) + ", " + std::to_string(min_motion) + ", " +
        std::to_string(max_range) + ")");
  // KISS-ICP seeds the mean with the initial threshold as one sample.
  samples_.push_back({initial_threshold * initial_threshold, 0.0, 0.0});
  sum_ = samples_.back();
}

double
motionDisplacement(const Eigen::Matrix4d& d, double range)
{
  return d.topRightCorner<3, 1>().norm() +
         2.0 * range * std::sin(0.5 * rotationAngle(d.topLeftCorner<3, 3>()));
}

double
AdaptiveThreshold::modelError(const Eigen::Matrix4d& deviation) const
{
  return motionDisplacement(deviation, max_range_);
}

void
AdaptiveThreshold::updateModelDeviation(const Eigen::Matrix4d& deviation)
{
  if (!deviation.allFinite())
    throw std::invalid_argument("AdaptiveThreshold: non-finite model deviation");
  const double e = modelError(deviation);
  if (e <= min_motion_) // standing still says nothing about the prediction's error
    return;
  const double theta = rotationAngle(deviation.topLeftCorner<3, 3>());
  const Sample s{e * e, deviation.topRightCorner<3, 1>().squaredNorm(), theta * theta};
  samples_.push_back(s);
  if (window_ > 0 && samples_.size() > window_) {
    samples_.pop_front();
    seeded_ = false;
    resum();
  }
  else
    sum_ += s;
}

void
AdaptiveThreshold::resum()
{
  sum_ = {0.0, 0.0, 0.0};
  for (const Sample& s : samples_)
    sum_ += s;
}

double
AdaptiveThreshold::sigma() const
{
  return std::sqrt(sum_.error2 / static_cast<double>(samples_.size()));
}

double
AdaptiveThreshold::translationSigma() const
{
  const std::size_t n = numDeviations();
  return n > 0 ? std::sqrt(sum_.translation2 / static_cast<double>(n)) : 0.0;
}

double
AdaptiveThreshold::rotationSigma() const
{
  const std::size_t n = numDeviations();
  return n > 0 ? std::sqrt(sum_.rotation2 / static_cast<double>(n)) : 0.0;
}

} // namespace registration
} // namespace pcl_parallel
