/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/kdtree.h>

#include <cstdint>

namespace pcl_parallel {

/** A rigid transform as the search uses it: row-major 3x4 in float (the tree is float). */
struct SearchTransform {
  /** Row-major 3x4 entries. */
  float m[12];

  /** The transform \a t (4x4, any scalar) rounded to float. */
  template <typename Matrix>
  static SearchTransform
  from(const Matrix& t)
  {
    SearchTransform s;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        s.m[4 * r + c] = static_cast<float>(t(r, c));
    return s;
  }
};

/** "Transform, then nearest": \a p moved by \a tr into \a q, then its closest point in
 *  \a tree within max_sqr_dist searched in the caller's (padded, per-thread) slot, warm
 *  started from \a hint (paper Sec. IV-A.3, IV-B). Returns the position or kInvalid. */
inline std::uint32_t
transformedNearest(const KdTreeIndex& tree,
                   NearestSlot& slot,
                   const SearchTransform& tr,
                   const float* p,
                   float* q,
                   float max_sqr_dist,
                   std::uint32_t hint = KdTreeIndex::kInvalid)
{
  const float* m = tr.m;
  for (int r = 0; r < 3; ++r)
    q[r] = m[4 * r] * p[0] + m[4 * r + 1] * p[1] + m[4 * r + 2] * p[2] + m[4 * r + 3];
  slot.query = q;
  return tree.nearest(slot, max_sqr_dist, hint);
}

} // namespace pcl_parallel
