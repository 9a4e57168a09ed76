/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "../extern_templates.h"

#include <pcl_parallel/point_types.h>
#include <pcl_parallel/registration/impl/lum.hpp>

#include <pcl/impl/instantiate.hpp>
#include <pcl/point_types.h>

// PCL_INSTANTIATE(X, types) expands PCL_INSTANTIATE_X(T) for each type.
PCL_INSTANTIATE(ParallelLUM, PCL_PARALLEL_XYZ_POINT_TYPES)
