/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/registration/mixed_point_types.h>

// Same member initialisation as PCL 1.13's constructor, except that the reciprocal tree
// gets the type its member is declared with (KdTree<PointTarget>).
#define PCL_PARALLEL_DEFINE_MIXED_BASE_CTOR(S, T, SCALAR)                                  \
  template <>                                                                              \
  CorrespondenceEstimationBase<S, T, SCALAR>::CorrespondenceEstimationBase()               \
  : corr_name_("CorrespondenceEstimationBase")                                             \
  , tree_(new pcl::search::KdTree<T>)                                                      \
  , tree_reciprocal_(new pcl::search::KdTree<T>)                                           \
  , target_()                                                                              \
  , point_representation_()                                                                \
  , input_transformed_()                                                                   \
  , target_cloud_updated_(true)                                                            \
  , source_cloud_updated_(true)                                                            \
  , force_no_recompute_(false)                                                             \
  , force_no_recompute_reciprocal_(false)                                                  \
  {}

namespace pcl {
namespace registration {
PCL_PARALLEL_DEFINE_MIXED_BASE_CTOR(pcl::PointXYZ, pcl::PointNormal, float)
PCL_PARALLEL_DEFINE_MIXED_BASE_CTOR(pcl::PointXYZ, pcl::PointNormal, double)
PCL_PARALLEL_DEFINE_MIXED_BASE_CTOR(pcl::PointNormal, pcl::PointXYZ, float)
PCL_PARALLEL_DEFINE_MIXED_BASE_CTOR(pcl::PointNormal, pcl::PointXYZ, double)
} // namespace registration
} // namespace pcl
