/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/kdtree.h>

#include <pcl/search/kdtree.h>

#include <memory>

namespace pcl_parallel {
namespace search {

/**
 * \brief pcl::search::KdTree backed by pcl_parallel::KdTreeIndex.
 *
 * It *is* a pcl::search::KdTree, so it goes wherever PCL takes one
 * (Registration::setSearchMethodTarget, CorrespondenceEstimation, NormalEstimation, ...),
 * and every PCL search call through a base pointer reaches this tree, not FLANN.
 * Differences from PCL's class, all documented behaviour:
 * - search is always exact (setEpsilon() is ignored) and uses x, y, z only (a custom
 *   setPointRepresentation() is ignored);
 * - the batch nearestKSearch / radiusSearch over a cloud run in parallel
 *   (setNumberOfThreads());
 * - non-finite points are never inserted; a non-finite query finds nothing;
 * - an input cloud without finite points is reported with PCL_ERROR and leaves an empty
 *   tree whose searches return 0 neighbours.
 * Equidistant neighbours may come in a different order than FLANN's.
 */
template <typename PointT>
class KdTree : public pcl::search::KdTree<PointT> {
public:
  /** Shared pointer, as PCL's. */
  using Ptr = pcl::shared_ptr<KdTree<PointT>>;
  /** Shared pointer to const, as PCL's. */
  using ConstPtr = pcl::shared_ptr<const KdTree<PointT>>;
  /** Cloud type. */
  using PointCloud = typename pcl::search::Search<PointT>::PointCloud;
  /** Shared pointer to a const cloud. */
  using PointCloudConstPtr = typename pcl::search::Search<PointT>::PointCloudConstPtr;
  /** Shared pointer to const indices. */
  using IndicesConstPtr = typename pcl::search::Search<PointT>::IndicesConstPtr;

  using pcl::search::Search<PointT>::nearestKSearch;
  using pcl::search::Search<PointT>::radiusSearch;

  /** An empty tree; \a sorted: radius results sorted by distance, as PCL's. */
  explicit KdTree(bool sorted = true);
  ~KdTree() override = default;

  /** Builds the tree (in parallel) over the finite points of \a cloud (or its
   *  \a indices); the indices returned by searches refer to \a cloud. */
  void
  setInputCloud(const PointCloudConstPtr& cloud,
                const IndicesConstPtr& indices = IndicesConstPtr()) override;

  /** Searches \a cloud with a tree already built over it: KdTreeIndex::build over all
   *  its points with the ids left to be the cloud indices (what setInputCloud(cloud)
   *  builds), e.g. one shared with ParallelLUM::setSearchTree, so that a cloud's tree is
   *  built once. Throws std::invalid_argument for a null index, or one whose size is not
   *  the cloud's number of finite points or whose ids lie outside it. */
  void
  setInputCloudAndIndex(const PointCloudConstPtr& cloud,
                        std::shared_ptr<const KdTreeIndex> index);

  /** The k nearest neighbours of \a point, as PCL's. */
  int
  nearestKSearch(const PointT& point,
                 int k,
                 pcl::Indices& k_indices,
                 std::vector<float>& k_sqr_distances) const override;

  /** The neighbours of \a point within \a radius, as PCL's. */
  int
  radiusSearch(const PointT& point,
               double radius,
               pcl::Indices& k_indices,
               std::vector<float>& k_sqr_distances,
               unsigned int max_nn = 0) const override;

  /** Parallel k-NN for many queries (PCL's batch interface). */
  void
  nearestKSearch(const PointCloud& cloud,
                 const pcl::Indices& indices,
                 int k,
                 std::vector<pcl::Indices>& k_indices,
                 std::vector<std::vector<float>>& k_sqr_distances) const override;

  /** Parallel radius search for many queries (PCL's batch interface). */
  void
  radiusSearch(const PointCloud& cloud,
               const pcl::Indices& indices,
               double radius,
               std::vector<pcl::Indices>& k_indices,
               std::vector<std::vector<float>>& k_sqr_distances,
               unsigned int max_nn = 0) const override;

  /** Threads for building and batch searches; 0 (default) = all cores. */
  void
  setNumberOfThreads(unsigned num_threads)
  {
    num_threads_ = num_threads;
  }
  /** Threads used by batch searches (0: all cores). */
  unsigned
  getNumberOfThreads() const
  {
    return num_threads_;
  }

  /** Points per leaf, used from the next setInputCloud(). */
  void
  setBucketSize(unsigned bucket_size)
  {
    bucket_size_ = bucket_size;
  }

  /** The underlying index (positions map to cloud indices through index().id()). */
  const KdTreeIndex&
  index() const
  {
    return *index_;
  }
  /** The same, shared (it stays valid after the next setInputCloud()). */
  const std::shared_ptr<const KdTreeIndex>&
  sharedIndex() const
  {
    return index_;
  }

protected:
  using pcl::search::Search<PointT>::input_;
  using pcl::search::Search<PointT>::indices_;
  using pcl::search::Search<PointT>::sorted_results_;
  using pcl::search::Search<PointT>::name_;

private:
  /** The parallel loop of the batch searches: search_one(point, indices, sqr_distances)
   *  for every query (all of \a cloud when \a indices is empty, as PCL). */
  template <typename SearchOne>
  void
  searchBatch(const PointCloud& cloud,
              const pcl::Indices& indices,
              std::vector<pcl::Indices>& k_indices,
              std::vector<std::vector<float>>& k_sqr_distances,
              SearchOne search_one) const;

  std::shared_ptr<const KdTreeIndex> index_ = std::make_shared<KdTreeIndex>();
  unsigned num_threads_ = 0;
  unsigned bucket_size_ = KdTreeIndex::kDefaultBucketSize;
};

} // namespace search
} // namespace pcl_parallel

#ifdef PCL_NO_PRECOMPILE
#include <pcl_parallel/search/impl/kdtree.hpp>
#endif
