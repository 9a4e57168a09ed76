/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

/**
 * \file
 * Workaround for registering clouds of different point types with PCL 1.13.
 *
 * PCL 1.13's CorrespondenceEstimationBase<PointSource, PointTarget> declares its
 * reciprocal tree as a pcl::search::KdTree<PointTarget> but initialises it with a
 * KdTree<PointSource>, so its constructor (and with it every registration class) does not
 * compile when the two types differ. We declare explicit specialisations of that
 * constructor, defined in src/registration/mixed_point_types.cpp, for the mixed pairs
 * pcl_parallel instantiates: PointXYZ -> PointNormal and PointNormal -> PointXYZ, with
 * float and double Scalar. Include this header (every pcl_parallel registration header
 * does) before anything instantiates those classes.
 *
 * pcl::IterativeClosestPoint's constructor also instantiates PCL's own
 * CorrespondenceEstimation<PointSource, PointTarget>, whose determineCorrespondences and
 * determineReciprocalCorrespondences do not compile for different types either (the
 * same-type branch passes a PointSource to a KdTree<PointTarget>; the reciprocal tree has
 * the target's type but is given the source cloud). We declare explicit specialisations
 * of both for the same mixed pairs; they keep PCL's semantics (the source point is copied
 * into a PointTarget for the search; the reciprocal search uses a private tree over a
 * PointTarget copy of the source) and live in src/registration/mixed_point_types.cpp.
 *
 * Finally, Registration<PointSource, PointTarget>::initCompute (called by every align())
 * hands its reciprocal tree, a KdTree<PointSource>, to the correspondence estimation,
 * which wants the mistyped KdTree<PointTarget>: it does not compile either. Its explicit
 * specialisation for the mixed pairs does what PCL's does except that hand-over (the
 * specialised reciprocal search above does not use that tree).
 */

#include <pcl/pcl_config.h>
#include <pcl/point_types.h>
#include <pcl/registration/correspondence_estimation.h>
#include <pcl/registration/registration.h>

// The specialisations below re-implement PCL 1.13's code of these members, and
// icp.h's FusedConvergenceCriteria / ParallelIterativeClosestPoint read protected members
// of DefaultConvergenceCriteria and Registration (both include this header). Another PCL
// may have fixed the mixed-type bug (1.14 did some of it) or renamed those members: stop
// here with the reason rather than compile code that silently diverges from PCL.
#if PCL_MAJOR_VERSION != 1 || PCL_MINOR_VERSION != 13
#error "pcl_parallel is written against PCL 1.13: mixed_point_types.h re-implements PCL 1.13 \
internals (CorrespondenceEstimationBase ctor, determine*Correspondences, initCompute) and \
icp.h reads DefaultConvergenceCriteria's protected state. Port and re-test both for this PCL."
#endif

/** Declares PCL's CorrespondenceEstimationBase constructor specialised for source type S and
 *  target type T. */
#define PCL_PARALLEL_DECLARE_MIXED_BASE_CTOR(S, T, SCALAR)                                     \
  template <>                                                                                  \
  CorrespondenceEstimationBase<S, T, SCALAR>::CorrespondenceEstimationBase();

/** Declares PCL's CorrespondenceEstimation::determine(Reciprocal)Correspondences specialised
 *  for S and T. */
#define PCL_PARALLEL_DECLARE_MIXED_CE(S, T, SCALAR)                                            \
  template <>                                                                                  \
  void CorrespondenceEstimation<S, T, SCALAR>::determineCorrespondences(                       \
      pcl::Correspondences& correspondences, double max_distance);                             \
  template <>                                                                                  \
  void CorrespondenceEstimation<S, T, SCALAR>::determineReciprocalCorrespondences(             \
      pcl::Correspondences& correspondences, double max_distance);

/** Declares PCL's Registration::initCompute specialised for S and T. */
#define PCL_PARALLEL_DECLARE_MIXED_INIT(S, T, SCALAR)                                          \
  template <>                                                                                  \
  bool Registration<S, T, SCALAR>::initCompute();

namespace pcl {
PCL_PARALLEL_DECLARE_MIXED_INIT(pcl::PointXYZ, pcl::PointNormal, float)
PCL_PARALLEL_DECLARE_MIXED_INIT(pcl::PointXYZ, pcl::PointNormal, double)
PCL_PARALLEL_DECLARE_MIXED_INIT(pcl::PointNormal, pcl::PointXYZ, float)
PCL_PARALLEL_DECLARE_MIXED_INIT(pcl::PointNormal, pcl::PointXYZ, double)
namespace registration {
PCL_PARALLEL_DECLARE_MIXED_CE(pcl::PointXYZ, pcl::PointNormal, float)
PCL_PARALLEL_DECLARE_MIXED_CE(pcl::PointXYZ, pcl::PointNormal, double)
PCL_PARALLEL_DECLARE_MIXED_CE(pcl::PointNormal, pcl::PointXYZ, float)
PCL_PARALLEL_DECLARE_MIXED_CE(pcl::PointNormal, pcl::PointXYZ, double)
PCL_PARALLEL_DECLARE_MIXED_BASE_CTOR(pcl::PointXYZ, pcl::PointNormal, float)
PCL_PARALLEL_DECLARE_MIXED_BASE_CTOR(pcl::PointXYZ, pcl::PointNormal, double)
PCL_PARALLEL_DECLARE_MIXED_BASE_CTOR(pcl::PointNormal, pcl::PointXYZ, float)
PCL_PARALLEL_DECLARE_MIXED_BASE_CTOR(pcl::PointNormal, pcl::PointXYZ, double)
} // namespace registration
} // namespace pcl

#undef PCL_PARALLEL_DECLARE_MIXED_BASE_CTOR
#undef PCL_PARALLEL_DECLARE_MIXED_CE
#undef PCL_PARALLEL_DECLARE_MIXED_INIT
