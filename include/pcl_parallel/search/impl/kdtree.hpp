/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/search/kdtree.h>

#include <pcl/console/print.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace pcl_parallel {
namespace search {

namespace detail {
/** PCL's clouds store x, y, z first and then padding or other fields. */
template <typename PointT>
constexpr std::size_t
floatStride()
{
  static_assert(sizeof(PointT) % sizeof(float) == 0, "point type must be float-aligned");
  return sizeof(PointT) / sizeof(float);
}

template <typename PointT>
void
buildIndex(KdTreeIndex& index,
           const pcl::PointCloud<PointT>* cloud,
           const pcl::Indices* indices,
           unsigned num_threads,
           unsigned bucket_size)
{
  static_assert(sizeof(pcl::index_t) == sizeof(std::uint32_t), "32-bit pcl::index_t expected");
  if (!cloud || cloud->empty()) {
    index.build(nullptr, 0, 3, nullptr, num_threads, bucket_size);
    return;
  }
  const float* xyz = cloud->front().data;
  constexpr std::size_t stride = floatStride<PointT>();
  if (!indices) {
    index.build(xyz, cloud->size(), stride, nullptr, num_threads, bucket_size);
    return;
  }
  // Gather the selected points; ids stay cloud indices. An out-of-range index is an
  // error, not undefined behaviour.
  std::vector<float> selected;
  std::vector<std::uint32_t> ids;
  selected.reserve(3 * indices->size());
  ids.reserve(indices->size());
  for (const auto i : *indices) {
    if (i < 0 || static_cast<std::size_t>(i) >= cloud->size()) {
      PCL_ERROR("[pcl_parallel] Index %d out of range (cloud has %zu points); ignored.\n",
                static_cast<int>(i),
                cloud->size());
      continue;
    }
    const float* p = xyz + static_cast<std::size_t>(i) * stride;
    selected.insert(selected.end(), p, p + 3);
    ids.push_back(static_cast<std::uint32_t>(i));
  }
  index.build(selected.data(), ids.size(), 3, ids.data(), num_threads, bucket_size);
}
/** Throws std::invalid_argument (message after `where`) unless \a index could be the tree
 *  buildIndex builds over all of \a cloud: as many points as the cloud has finite ones,
 *  ids inside the cloud. A null cloud or index does not fit. */
template <typename PointT>
void
checkIndexFits(const pcl::PointCloud<PointT>* cloud,
               const KdTreeIndex* index,
               const char* where)
{
  if (!cloud || !index)
    throw std::invalid_argument(std::string(where) + "null cloud or index");
  std::size_t finite = 0;
  for (const PointT& p : *cloud)
    finite += std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) ? 1 : 0;
  bool ids_inside = true;
  for (std::uint32_t pos = 0; pos < index->size() && ids_inside; ++pos)
    ids_inside = index->id(pos) < cloud->size();
  if (index->size() != finite || !ids_inside)
    throw std::invalid_argument(std::string(where) + "the index holds " +
                                std::to_string(index->size()) + " points, not the cloud's " +
                                std::to_string(finite) + " finite points" +
                                (ids_inside ? "" : " (ids out of range)"));
}
} // namespace detail

template <typename PointT>
KdTree<PointT>::KdTree(bool sorted)
    : pcl::search::KdTree<PointT>(sorted)
{
  name_ = "pcl_parallel::KdTree";
}

template <typename PointT>
void
KdTree<PointT>::setInputCloud(const PointCloudConstPtr& cloud, const IndicesConstPtr& indices)
{
  input_ = cloud;
  indices_ = indices;
  if (!cloud)
    PCL_ERROR("[pcl_parallel::KdTree::setInputCloud] Null input cloud.\n");
  auto index = std::make_shared<KdTreeIndex>();
  detail::buildIndex(*index, cloud.get(), indices.get(), num_threads_, bucket_size_);
  index_ = std::move(index);
  if (index_->empty())
    PCL_ERROR("[pcl_parallel::KdTree::setInputCloud] The input cloud has no finite points; "
              "searches will find nothing.\n");
}

template <typename PointT>
void
KdTree<PointT>::setInputCloudAndIndex(const PointCloudConstPtr& cloud,
                                      std::shared_ptr<const KdTreeIndex> index)
{
  detail::checkIndexFits(
      cloud.get(), index.get(), "[pcl_parallel::KdTree::setInputCloudAndIndex] ");
  input_ = cloud;
  indices_.reset();
  index_ = std::move(index);
}

template <typename PointT>
int
KdTree<PointT>::nearestKSearch(const PointT& point,
                               int k,
                               pcl::Indices& k_indices,
                               std::vector<float>& k_sqr_distances) const
{
  const std::size_t kk = k > 0 ? std::min<std::size_t>(k, index_->size()) : 0;
  std::vector<std::uint32_t> pos(kk);
  k_sqr_distances.resize(kk);
  const std::size_t found = index_->knn(point.data, kk, pos.data(), k_sqr_distances.data());
  k_indices.resize(found);
  k_sqr_distances.resize(found);
  for (std::size_t i = 0; i < found; ++i)
    k_indices[i] = static_cast<pcl::index_t>(index_->id(pos[i]));
  return static_cast<int>(found);
}

template <typename PointT>
int
KdTree<PointT>::radiusSearch(const PointT& point,
                             double radius,
                             pcl::Indices& k_indices,
                             std::vector<float>& k_sqr_distances,
                             unsigned int max_nn) const
{
  std::vector<std::uint32_t> pos;
  index_->radius(point.data,
                 static_cast<float>(radius * radius),
                 pos,
                 k_sqr_distances,
                 max_nn,
                 sorted_results_);
  k_indices.resize(pos.size());
  for (std::size_t i = 0; i < pos.size(); ++i)
    k_indices[i] = static_cast<pcl::index_t>(index_->id(pos[i]));
  return static_cast<int>(pos.size());
}

template <typename PointT>
template <typename SearchOne>
void
KdTree<PointT>::searchBatch(const PointCloud& cloud,
                            const pcl::Indices& indices,
                            std::vector<pcl::Indices>& k_indices,
                            std::vector<std::vector<float>>& k_sqr_distances,
                            SearchOne search_one) const
{
  // As PCL: empty indices mean every point of the cloud.
  const std::size_t n = indices.empty() ? cloud.size() : indices.size();
  k_indices.resize(n);
  k_sqr_distances.resize(n);
  const unsigned threads = resolveNumberOfThreads(num_threads_);
  parallelFor(n, threads, 64, [&](std::size_t first, std::size_t last) {
    for (std::size_t i = first; i < last; ++i) {
      const std::size_t q = indices.empty() ? i : static_cast<std::size_t>(indices[i]);
      search_one(cloud[q], k_indices[i], k_sqr_distances[i]);
    }
  });
}

template <typename PointT>
void
KdTree<PointT>::nearestKSearch(const PointCloud& cloud,
                               const pcl::Indices& indices,
                               int k,
                               std::vector<pcl::Indices>& k_indices,
                               std::vector<std::vector<float>>& k_sqr_distances) const
{
  searchBatch(
      cloud, indices, k_indices, k_sqr_distances, [&](const PointT& p, auto& i, auto& d) {
        nearestKSearch(p, k, i, d);
      });
}

template <typename PointT>
void
KdTree<PointT>::radiusSearch(const PointCloud& cloud,
                             const pcl::Indices& indices,
                             double radius,
                             std::vector<pcl::Indices>& k_indices,
                             std::vector<std::vector<float>>& k_sqr_distances,
                             unsigned int max_nn) const
{
  searchBatch(
      cloud, indices, k_indices, k_sqr_distances, [&](const PointT& p, auto& i, auto& d) {
        radiusSearch(p, radius, i, d, max_nn);
      });
}

} // namespace search
} // namespace pcl_parallel
