/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

/** Point types every template of pcl_parallel is compiled for in src/ (PCL's
 *  explicit-instantiation pattern). For another type, include the matching impl/ header.
 *  Built with PCL_PARALLEL_MINIMAL_POINT_TYPES (a CMake option, as PCL's
 *  PCL_ONLY_CORE_POINT_TYPES): the three the tests use. */
#ifdef PCL_PARALLEL_MINIMAL_POINT_TYPES
#define PCL_PARALLEL_XYZ_POINT_TYPES (pcl::PointXYZ)(pcl::PointXYZRGB)(pcl::PointNormal)
#else
#define PCL_PARALLEL_XYZ_POINT_TYPES                                                           \
  (pcl::PointXYZ)(pcl::PointXYZI)(pcl::PointXYZRGB)(pcl::PointXYZRGBA)(pcl::PointNormal)(      \
      pcl::PointXYZINormal)(pcl::PointXYZRGBNormal)
#endif
