/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/registration/mixed_point_types.h>

#include <pcl/common/io.h>
#include <pcl/search/kdtree.h>

namespace {

/** PCL 1.13's CorrespondenceEstimation::determineCorrespondences, different-type branch:
 *  the source point is copied into a PointTarget and searched in the target tree. */
template <typename S, typename T>
void
mixedCorrespondences(pcl::search::KdTree<T>& tree,
                     const pcl::PointCloud<S>& input,
                     const pcl::Indices& indices,
                     double max_distance,
                     pcl::Correspondences& correspondences)
{
  const double max_dist_sqr = max_distance * max_distance;
  correspondences.clear();
  correspondences.reserve(indices.size());
  pcl::Indices index(1);
  std::vector<float> distance(1);
  T pt;
  for (const auto idx : indices) {
    pcl::copyPoint(input[idx], pt);
    if (tree.nearestKSearch(pt, 1, index, distance) < 1 || distance[0] > max_dist_sqr)
      continue;
    correspondences.emplace_back(idx, index[0], distance[0]);
  }
}

/** PCL's reciprocal branch. PCL's reciprocal tree has the target's type, so it searches
 *  a private tree over a PointTarget copy of the (indexed) source. */
template <typename S, typename T>
void
mixedReciprocalCorrespondences(pcl::search::KdTree<T>& tree,
                               const pcl::PointCloud<S>& input,
                               const pcl::Indices& indices,
                               const pcl::PointCloud<T>& target,
                               double max_distance,
                               pcl::Correspondences& correspondences)
{
  const double max_dist_sqr = max_distance * max_distance;
  correspondences.clear();
  typename pcl::PointCloud<T>::Ptr source_as_target(new pcl::PointCloud<T>);
  pcl::copyPointCloud(input, indices, *source_as_target);
  pcl::search::KdTree<T> reciprocal;
  reciprocal.setInputCloud(source_as_target);
  pcl::Indices index(1), index_reciprocal(1);
  std::vector<float> distance(1), distance_reciprocal(1);
  T pt;
  for (const auto idx : indices) {
    pcl::copyPoint(input[idx], pt);
    if (tree.nearestKSearch(pt, 1, index, distance) < 1 || distance[0] > max_dist_sqr)
      continue;
    if (reciprocal.nearestKSearch(target[index[0]], 1, index_reciprocal, distance_reciprocal) <
            1 ||
        distance_reciprocal[0] > max_dist_sqr || idx != indices[index_reciprocal[0]])
      continue;
    correspondences.emplace_back(idx, index[0], distance[0]);
  }
}

} // namespace

#define PCL_PARALLEL_DEFINE_MIXED_CE(S, T, SCALAR)                                             \
  template <>                                                                                  \
  void CorrespondenceEstimation<S, T, SCALAR>::determineCorrespondences(                       \
      pcl::Correspondences& correspondences, double max_distance)                              \
  {                                                                                            \
    correspondences.clear();                                                                   \
    if (!initCompute())                                                                        \
      return;                                                                                  \
    mixedCorrespondences<S, T>(*tree_, *input_, *indices_, max_distance, correspondences);     \
    deinitCompute();                                                                           \
  }                                                                                            \
  template <>                                                                                  \
  void CorrespondenceEstimation<S, T, SCALAR>::determineReciprocalCorrespondences(             \
      pcl::Correspondences& correspondences, double max_distance)                              \
  {                                                                                            \
    correspondences.clear();                                                                   \
    if (!initCompute())                                                                        \
      return;                                                                                  \
    mixedReciprocalCorrespondences<S, T>(                                                      \
        *tree_, *input_, *indices_, *target_, max_distance, correspondences);                  \
    deinitCompute();                                                                           \
  }

// Same member initialisation as PCL 1.13's constructor, except that the reciprocal tree
// gets the type its member is declared with (KdTree<PointTarget>).
#define PCL_PARALLEL_DEFINE_MIXED_BASE_CTOR(S, T, SCALAR)                                      \
  template <>                                                                                  \
  CorrespondenceEstimationBase<S, T, SCALAR>::CorrespondenceEstimationBase()                   \
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

// PCL 1.13's Registration::initCompute without handing the (differently typed)
// reciprocal tree to the correspondence estimation.
#define PCL_PARALLEL_DEFINE_MIXED_INIT(S, T, SCALAR)                                           \
  template <>                                                                                  \
  bool Registration<S, T, SCALAR>::initCompute()                                               \
  {                                                                                            \
    if (!target_) {                                                                            \
      PCL_ERROR("[pcl::registration::%s::compute] No input target dataset was given!\n",       \
                getClassName().c_str());                                                       \
      return false;                                                                            \
    }                                                                                          \
    if (target_cloud_updated_ && !force_no_recompute_) {                                       \
      tree_->setInputCloud(target_);                                                           \
      target_cloud_updated_ = false;                                                           \
    }                                                                                          \
    if (correspondence_estimation_)                                                            \
      correspondence_estimation_->setSearchMethodTarget(tree_, force_no_recompute_);           \
    return PCLBase<S>::initCompute();                                                          \
  }

namespace pcl {
PCL_PARALLEL_DEFINE_MIXED_INIT(pcl::PointXYZ, pcl::PointNormal, float)
PCL_PARALLEL_DEFINE_MIXED_INIT(pcl::PointXYZ, pcl::PointNormal, double)
PCL_PARALLEL_DEFINE_MIXED_INIT(pcl::PointNormal, pcl::PointXYZ, float)
PCL_PARALLEL_DEFINE_MIXED_INIT(pcl::PointNormal, pcl::PointXYZ, double)
namespace registration {
PCL_PARALLEL_DEFINE_MIXED_CE(pcl::PointXYZ, pcl::PointNormal, float)
PCL_PARALLEL_DEFINE_MIXED_CE(pcl::PointXYZ, pcl::PointNormal, double)
PCL_PARALLEL_DEFINE_MIXED_CE(pcl::PointNormal, pcl::PointXYZ, float)
PCL_PARALLEL_DEFINE_MIXED_CE(pcl::PointNormal, pcl::PointXYZ, double)
PCL_PARALLEL_DEFINE_MIXED_BASE_CTOR(pcl::PointXYZ, pcl::PointNormal, float)
PCL_PARALLEL_DEFINE_MIXED_BASE_CTOR(pcl::PointXYZ, pcl::PointNormal, double)
PCL_PARALLEL_DEFINE_MIXED_BASE_CTOR(pcl::PointNormal, pcl::PointXYZ, float)
PCL_PARALLEL_DEFINE_MIXED_BASE_CTOR(pcl::PointNormal, pcl::PointXYZ, double)
} // namespace registration
} // namespace pcl
