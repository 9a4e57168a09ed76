/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "../extern_templates.h"

#include <pcl_parallel/point_types.h>
#include <pcl_parallel/registration/impl/correspondence_estimation.hpp>

#include <pcl/impl/instantiate.hpp>
#include <pcl/point_types.h>

#include <cmath>
#include <limits>

namespace pcl_parallel {
namespace registration {

float
sqrDistanceBound(double max_distance)
{
  const double bound = max_distance * max_distance;
  if (std::isnan(bound) || max_distance < 0.0)
    return -1.0f; // nothing matches
  if (bound >= static_cast<double>(std::numeric_limits<float>::max()))
    return std::numeric_limits<float>::infinity();
  float f = static_cast<float>(bound);
  if (static_cast<double>(f) > bound)
    f = std::nextafter(f, 0.0f);
  return f;
}

} // namespace registration
} // namespace pcl_parallel

#define PCL_PARALLEL_INSTANTIATE_CE(S, T, SCALAR)                                              \
  template class pcl_parallel::registration::ParallelCorrespondenceEstimation<S, T, SCALAR>;
// PCL_INSTANTIATE(X, types) expands PCL_INSTANTIATE_X(T) for each type.
#define PCL_INSTANTIATE_ParallelCorrespondenceEstimation(T)                                    \
  PCL_PARALLEL_INSTANTIATE_CE(T, T, float) PCL_PARALLEL_INSTANTIATE_CE(T, T, double)
PCL_INSTANTIATE(ParallelCorrespondenceEstimation, PCL_PARALLEL_XYZ_POINT_TYPES)
PCL_PARALLEL_INSTANTIATE_CE(pcl::PointXYZ, pcl::PointNormal, float)
PCL_PARALLEL_INSTANTIATE_CE(pcl::PointXYZ, pcl::PointNormal, double)
PCL_PARALLEL_INSTANTIATE_CE(pcl::PointNormal, pcl::PointXYZ, float)
PCL_PARALLEL_INSTANTIATE_CE(pcl::PointNormal, pcl::PointXYZ, double)
