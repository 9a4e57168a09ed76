/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/filters/voxel_grid.h>
#include <pcl_parallel/parallel.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace filters {

namespace {

struct Keyed {
  std::array<std::int32_t, 3> key;
  std::uint32_t index;
  bool
  operator<(const Keyed& o) const
  {
    return key != o.key ? key < o.key : index < o.index;
  }
};

} // namespace

pcl::PointCloud<pcl::PointXYZ>::Ptr
voxelCentroid(const pcl::PointCloud<pcl::PointXYZ>& cloud,
              double voxel_size,
              unsigned num_threads)
{
  pcl::PointCloud<pcl::PointXYZ>::Ptr out(new pcl::PointCloud<pcl::PointXYZ>);
  if (cloud.size() > std::numeric_limits<std::uint32_t>::max())
    throw std::invalid_argument("voxelCentroid: more than 2^32 points");
  const std::int64_t n = static_cast<std::int64_t>(cloud.size());
  auto finite = [&](std::int64_t i) {
    return std::isfinite(cloud[i].x) && std::isfinite(cloud[i].y) && std::isfinite(cloud[i].z);
  };
  if (!(voxel_size > 0.0)) {
    for (std::int64_t i = 0; i < n; ++i)
      if (finite(i))
        out->push_back(cloud[i]);
    return out;
  }
  // Voxel keys: floor(p / voxel_size) per axis; non-finite points get no key.
  const double inv = 1.0 / voxel_size;
  constexpr double limit = 2147483647.0;
  std::vector<Keyed> keyed(cloud.size());
  std::vector<char> valid(cloud.size(), 0);
  bool too_far = false;
  const unsigned threads = resolveNumberOfThreads(num_threads);
#pragma omp parallel for num_threads(threads) schedule(static)                                 \
    reduction(||                                                                               \
              : too_far) if (threads > 1 && n > 10000)
  for (std::int64_t i = 0; i < n; ++i) {
    if (!finite(i))
      continue;
    const double c[3] = {std::floor(cloud[i].x * inv),
                         std::floor(cloud[i].y * inv),
                         std::floor(cloud[i].z * inv)};
    if (std::abs(c[0]) >= limit || std::abs(c[1]) >= limit || std::abs(c[2]) >= limit) {
      too_far = true;
      continue;
    }
    keyed[i] = {{static_cast<std::int32_t>(c[0]),
                 static_cast<std::int32_t>(c[1]),
                 static_cast<std::int32_t>(c[2])},
                static_cast<std::uint32_t>(i)};
    valid[i] = 1;
  }
  if (too_far)
    throw std::invalid_argument("voxelCentroid: a point lies more than 2^31 voxels of " +
                                std::to_string(voxel_size) + " from the origin");
  std::size_t kept = 0;
  for (std::size_t i = 0; i < keyed.size(); ++i)
    if (valid[i])
      keyed[kept++] = keyed[i];
  keyed.resize(kept);
  std::sort(keyed.begin(), keyed.end());

  // One centroid per run of equal keys, summed in double in input order.
  for (std::size_t b = 0; b < keyed.size();) {
    std::size_t e = b;
    double sx = 0.0, sy = 0.0, sz = 0.0;
    for (; e < keyed.size() && keyed[e].key == keyed[b].key; ++e) {
      const auto& p = cloud[keyed[e].index];
      sx += p.x, sy += p.y, sz += p.z;
    }
    const double count = static_cast<double>(e - b);
    out->push_back(pcl::PointXYZ(static_cast<float>(sx / count),
                                 static_cast<float>(sy / count),
                                 static_cast<float>(sz / count)));
    b = e;
  }
  return out;
}

} // namespace filters
} // namespace pcl_parallel
