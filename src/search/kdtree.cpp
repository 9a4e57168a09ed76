/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "../extern_templates.h"

#include <pcl_parallel/point_types.h>
#include <pcl_parallel/search/impl/kdtree.hpp>

#include <pcl/impl/instantiate.hpp>
#include <pcl/point_types.h>

// PCL_INSTANTIATE(X, types) expands PCL_INSTANTIATE_X(T) for each type.
#define PCL_INSTANTIATE_ParallelSearchKdTree(T) template class pcl_parallel::search::KdTree<T>;
PCL_INSTANTIATE(ParallelSearchKdTree, PCL_PARALLEL_XYZ_POINT_TYPES)
