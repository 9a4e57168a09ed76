/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once
// The class templates that one unit of src/ instantiates and others use through their
// impl/ headers (pICP and pLUM search the k-d tree, pICP owns a correspondence estimation,
// DistributedLUM a ParallelLUM), declared instantiated elsewhere: each is compiled once,
// in its own unit. Included by every unit that includes an impl/ header.
#include <pcl_parallel/point_types.h>
#include <pcl_parallel/registration/correspondence_estimation.h>
#include <pcl_parallel/registration/lum.h>
#include <pcl_parallel/search/kdtree.h>

#include <pcl/impl/instantiate.hpp>
#include <pcl/point_types.h>

// PCL_INSTANTIATE(X, types) expands PCL_INSTANTIATE_X(T) for each type.
#define PCL_INSTANTIATE_ExternSearchKdTree(T)                                                  \
  extern template class pcl_parallel::search::KdTree<T>;
#define PCL_INSTANTIATE_ExternParallelLUM(T) extern template class pcl_parallel::ParallelLUM<T>;
#define PCL_PARALLEL_EXTERN_CE(S, T, SCALAR)                                                   \
  extern template class pcl_parallel::registration::                                           \
      ParallelCorrespondenceEstimation<S, T, SCALAR>;
#define PCL_INSTANTIATE_ExternParallelCorrespondenceEstimation(T)                              \
  PCL_PARALLEL_EXTERN_CE(T, T, float) PCL_PARALLEL_EXTERN_CE(T, T, double)

PCL_INSTANTIATE(ExternSearchKdTree, PCL_PARALLEL_XYZ_POINT_TYPES)
PCL_INSTANTIATE(ExternParallelLUM, PCL_PARALLEL_XYZ_POINT_TYPES)
PCL_INSTANTIATE(ExternParallelCorrespondenceEstimation, PCL_PARALLEL_XYZ_POINT_TYPES)
PCL_PARALLEL_EXTERN_CE(pcl::PointXYZ, pcl::PointNormal, float)
PCL_PARALLEL_EXTERN_CE(pcl::PointXYZ, pcl::PointNormal, double)
PCL_PARALLEL_EXTERN_CE(pcl::PointNormal, pcl::PointXYZ, float)
PCL_PARALLEL_EXTERN_CE(pcl::PointNormal, pcl::PointXYZ, double)
