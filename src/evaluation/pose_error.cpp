/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/evaluation/pose_error.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace pcl_parallel {
namespace evaluation {

Statistics
computeStatistics(std::vector<double> values)
{
  Statistics s;
  s.count = values.size();
  if (values.empty())
    return s;
  const double n = static_cast<double>(values.size());
  double sum = 0.0, sum_sq = 0.0;
  for (double v : values) {
    sum += v;
    sum_sq += v * v;
  }
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double var = 0.0; // two passes: sum_sq / n - mean² cancels for small spreads
  for (double v : values)
    var += (v - s.mean) * (v - s.mean);
  s.std = std::sqrt(var / n);
  std::sort(values.begin(), values.end());
  s.min = values.front();
  s.max = values.back();
  const std::size_t mid = values.size() / 2;
  s.median = values.size() % 2 ? values[mid] : 0.5 * (values[mid - 1] + values[mid]);
  return s;
}

PoseErrorSummary
summarizePoseErrors(const Poses& a, const Poses& b, std::size_t first)
{
  if (a.size() != b.size())
    throw std::invalid_argument("pcl_parallel::evaluation: pose lists differ in size (" +
                                std::to_string(a.size()) + " vs " + std::to_string(b.size()) +
                                ")");
  std::vector<double> angles, distances;
  for (std::size_t i = first; i < a.size(); ++i) {
    const PoseError e = poseError(a[i], b[i]);
    angles.push_back(e.angle);
    distances.push_back(e.distance);
  }
  return {computeStatistics(std::move(angles)), computeStatistics(std::move(distances))};
}

} // namespace evaluation
} // namespace pcl_parallel
