/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "convert.h"

#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/parallel.h>

#include <cmath>
#include <limits>
#include <vector>

namespace pcl_parallel {
namespace python {

namespace {

/** KdTree: the library's KdTreeIndex (what search::KdTree and pICP search in), without a
 *  PCL cloud in between. */
class KdTree {
public:
  KdTree(const py::handle& points, const py::handle& threads, unsigned bucket_size)
  {
    if (bucket_size == 0)
      throw std::invalid_argument("bucket_size: must be >= 1");
    const FloatPoints p = toFloatPoints(points, "points");
    const unsigned t = toThreads(threads);
    withoutGil([&] { tree_.build(p.data, p.size, p.stride, nullptr, t, bucket_size); });
  }

  std::size_t
  size() const
  {
    return tree_.size();
  }

  py::tuple
  nearest(const py::handle& queries,
          long k,
          double max_distance,
          const py::handle& threads) const
  {
    if (k < 1)
      throw std::invalid_argument("k: must be >= 1, got " + std::to_string(k));
    if (std::isnan(max_distance) || max_distance < 0.0)
      throw std::invalid_argument("max_distance: must be >= 0 (inf: no limit)");
    const FloatPoints q = toFloatPoints(queries, "queries");
    const unsigned t = toThreads(threads);
    // As the tree compares: squared, in float (inf stays inf).
    const float max_sqr = static_cast<float>(max_distance * max_distance);
    const std::size_t kk = static_cast<std::size_t>(k), n = q.size;
    py::array_t<long long> indices(k == 1 ? std::vector<py::ssize_t>{py::ssize_t(n)}
                                          : std::vector<py::ssize_t>{py::ssize_t(n), k});
    py::array_t<double> distances(indices.request().shape);
    long long* out_i = indices.mutable_data();
    double* out_d = distances.mutable_data();
    withoutGil([&] {
      if (kk == 1)
        nearestOne(q, max_sqr, t, out_i, out_d);
      else
        nearestK(q, kk, max_sqr, t, out_i, out_d);
    });
    return py::make_tuple(indices, distances);
  }

private:
  void
  nearestOne(
      const FloatPoints& q, float max_sqr, unsigned t, long long* idx, double* dist) const
  {
    std::vector<std::uint32_t> pos(q.size);
    std::vector<float> sqr(q.size);
    tree_.nearestBatch(q.data, q.size, q.stride, max_sqr, pos.data(), sqr.data(), t);
    for (std::size_t i = 0; i < q.size; ++i) {
      const bool found = pos[i] != KdTreeIndex::kInvalid;
      idx[i] = found ? static_cast<long long>(tree_.id(pos[i])) : -1;
      dist[i] = found ? std::sqrt(static_cast<double>(sqr[i]))
                      : std::numeric_limits<double>::infinity();
    }
  }

  void
  nearestK(const FloatPoints& q,
           std::size_t k,
           float max_sqr,
           unsigned t,
           long long* idx,
           double* dist) const
  {
    parallelFor(q.size, t, 64, [&](std::size_t begin, std::size_t end) {
      std::vector<std::uint32_t> pos(k);
      std::vector<float> sqr(k);
      for (std::size_t i = begin; i < end; ++i) {
        const std::size_t found = tree_.knn(q.data + i * q.stride, k, pos.data(), sqr.data());
        for (std::size_t j = 0; j < k; ++j) {
          const bool ok = j < found && sqr[j] <= max_sqr;
          idx[i * k + j] = ok ? static_cast<long long>(tree_.id(pos[j])) : -1;
          dist[i * k + j] = ok ? std::sqrt(static_cast<double>(sqr[j]))
                               : std::numeric_limits<double>::infinity();
        }
      }
    });
  }

  KdTreeIndex tree_;
};

} // namespace

void
bindSearch(py::module_& m)
{
  py::class_<KdTree>(m,
                     "KdTree",
                     "The parallel k-d tree (paper Sec. IV-A) over (N, 3) points; float32 rows "
                     "are searched in place, other layouts converted to float32 once.")
      .def(py::init<const py::handle&, const py::handle&, unsigned>(),
           py::arg("points"),
           py::kw_only(),
           py::arg("threads") = py::none(),
           py::arg("bucket_size") = KdTreeIndex::kDefaultBucketSize)
      .def("__len__", &KdTree::size)
      .def("nearest",
           &KdTree::nearest,
           py::arg("queries"),
           py::arg("k") = 1,
           py::kw_only(),
           py::arg("max_distance") = std::numeric_limits<double>::infinity(),
           py::arg("threads") = py::none(),
           "The k nearest points of each query within max_distance (inclusive), closest "
           "first: (indices, distances), int64 and float64 (Euclidean), shape (M,) for k=1 "
           "else (M, k); -1 and inf where there is none.");
}

} // namespace python
} // namespace pcl_parallel
