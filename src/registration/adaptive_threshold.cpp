/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/registration/adaptive_threshold.h>

#include <Eigen/Geometry>

#include <cmath>
#include <numeric>
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
  samples_.push_back(initial_threshold * initial_threshold);
  sse_ = samples_.back();
}

double
AdaptiveThreshold::modelError(const Eigen::Matrix4d& deviation) const
{
  // Rotation angle from sin (skew part) and cos (trace): acos alone loses small angles.
  const Eigen::Matrix4d& d = deviation;
  const Eigen::Vector3d w(d(2, 1) - d(1, 2), d(0, 2) - d(2, 0), d(1, 0) - d(0, 1));
  const double theta =
      std::atan2(0.5 * w.norm(), 0.5 * (d.topLeftCorner<3, 3>().trace() - 1.0));
  return deviation.topRightCorner<3, 1>().norm() + 2.0 * max_range_ * std::sin(0.5 * theta);
}

void
AdaptiveThreshold::updateModelDeviation(const Eigen::Matrix4d& deviation)
{
  if (!deviation.allFinite())
    throw std::invalid_argument("AdaptiveThreshold: non-finite model deviation");
  const double e = modelError(deviation);
  if (e <= min_motion_) // standing still says nothing about the prediction's error
    return;
  samples_.push_back(e * e);
  if (window_ > 0 && samples_.size() > window_) {
    samples_.pop_front();
    sse_ = std::accumulate(samples_.begin(), samples_.end(), 0.0);
  }
  else
    sse_ += e * e;
}

double
AdaptiveThreshold::sigma() const
{
  return std::sqrt(sse_ / static_cast<double>(samples_.size()));
}

} // namespace registration
} // namespace pcl_parallel
