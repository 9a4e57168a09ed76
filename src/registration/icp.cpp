/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
// GCC 12 reports -Warray-bounds / -Wuse-after-free false positives inside PCL 1.13's
// TransformationEstimationSVD (the default estimator pcl::IterativeClosestPoint's
// constructor instantiates here), not in our code: silence them for this file only.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Warray-bounds"
#pragma GCC diagnostic ignored "-Wuse-after-free"
#endif
#include "../extern_templates.h"

#include <pcl_parallel/point_types.h>
#include <pcl_parallel/registration/impl/icp.hpp>

#include <pcl/impl/instantiate.hpp>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace pcl_parallel {
namespace registration {
namespace detail {

namespace {
/** Spreads the low 21 bits of v to every third bit. */
std::uint64_t
spreadBits(std::uint64_t v)
{
  v &= 0x1fffff;
  v = (v | v << 32) & 0x1f00000000ffffULL;
  v = (v | v << 16) & 0x1f0000ff0000ffULL;
  v = (v | v << 8) & 0x100f00f00f00f00fULL;
  v = (v | v << 4) & 0x10c30c30c30c30c3ULL;
  v = (v | v << 2) & 0x1249249249249249ULL;
  return v;
}
} // namespace

void
spatialOrder(const float* xyz,
             std::size_t n,
             std::size_t stride,
             std::vector<std::uint32_t>& order)
{
  order.clear();
  // Indices are stored as uint32 (as the k-d tree's ids); a larger cloud is an error, not
  // a silent wrap-around.
  if (n >= std::numeric_limits<std::uint32_t>::max())
    throw std::invalid_argument("pICP: " + std::to_string(n) +
                                " source points; at most 2^32 - 2 are supported");
  float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
  for (std::size_t i = 0; i < n; ++i) {
    const float* p = xyz + i * stride;
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
      continue;
    for (int a = 0; a < 3; ++a) {
      lo[a] = order.empty() ? p[a] : std::min(lo[a], p[a]);
      hi[a] = order.empty() ? p[a] : std::max(hi[a], p[a]);
    }
    order.push_back(static_cast<std::uint32_t>(i));
  }
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(order.size());
  double scale[3];
  for (int a = 0; a < 3; ++a)
    scale[a] = hi[a] > lo[a] ? 2097151.0 / (static_cast<double>(hi[a]) - lo[a]) : 0.0;
  for (std::size_t k = 0; k < order.size(); ++k) {
    const float* p = xyz + static_cast<std::size_t>(order[k]) * stride;
    std::uint64_t code = 0;
    for (int a = 0; a < 3; ++a)
      code |= spreadBits(static_cast<std::uint64_t>(
                  std::min(2097151.0, (static_cast<double>(p[a]) - lo[a]) * scale[a])))
              << a; // 21 bits per axis, clamped: rounding must not spill into the next axis
    keyed[k] = {code, order[k]};
  }
  std::sort(keyed.begin(), keyed.end());
  for (std::size_t k = 0; k < keyed.size(); ++k)
    order[k] = keyed[k].second;
}

} // namespace detail
} // namespace registration
} // namespace pcl_parallel

template class pcl_parallel::registration::FusedConvergenceCriteria<float>;
template class pcl_parallel::registration::FusedConvergenceCriteria<double>;

#define PCL_PARALLEL_INSTANTIATE_ICP(S, T, SCALAR)                                             \
  template class pcl_parallel::registration::ParallelIterativeClosestPoint<S, T, SCALAR>;
// PCL_INSTANTIATE(X, types) expands PCL_INSTANTIATE_X(T) for each type.
#define PCL_INSTANTIATE_ParallelIterativeClosestPoint(T)                                       \
  PCL_PARALLEL_INSTANTIATE_ICP(T, T, float) PCL_PARALLEL_INSTANTIATE_ICP(T, T, double)
PCL_INSTANTIATE(ParallelIterativeClosestPoint, PCL_PARALLEL_XYZ_POINT_TYPES)
PCL_PARALLEL_INSTANTIATE_ICP(pcl::PointXYZ, pcl::PointNormal, float)
PCL_PARALLEL_INSTANTIATE_ICP(pcl::PointNormal, pcl::PointXYZ, float)
