/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/registration/loop_detection.h>

#include <algorithm>

namespace pcl_parallel {

std::vector<std::pair<std::uint32_t, std::uint32_t>>
detectLinksByDistance(const std::vector<Eigen::Matrix4d>& poses, double cldist, int loopsize)
{
  std::vector<std::pair<std::uint32_t, std::uint32_t>> links;
  const std::size_t n = poses.size();
  const std::size_t gap = static_cast<std::size_t>(std::max(loopsize, 2));
  const double sqr = cldist * cldist;
  for (std::size_t i = 0; i < n; ++i) {
    if (i + 1 < n)
      links.emplace_back(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(i + 1));
    if (!(cldist > 0.0))
      continue;
    // O(n^2) over positions: negligible next to one pair search per link.
    for (std::size_t j = i + gap; j < n; ++j)
      if ((poses[i].topRightCorner<3, 1>() - poses[j].topRightCorner<3, 1>()).squaredNorm() <
          sqr)
        links.emplace_back(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j));
  }
  std::sort(links.begin(), links.end());
  return links;
}

} // namespace pcl_parallel
