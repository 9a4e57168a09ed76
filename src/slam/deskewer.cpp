/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/filters/voxel_grid.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/slam/deskewer.h>
#include <pcl_parallel/slam/preprocess.h>

#include <Eigen/Geometry>

#include <algorithm>

namespace pcl_parallel {
namespace slam {

namespace {
/** Deskewed again where the matched step moves the farthest point by more than this many
 *  voxels from where the predicted one put it. */
constexpr double kRedeskewVoxels = 0.5;

/** How far deskewing by `b` instead of `a` moves the scan's farthest point, to first order:
 *  a point at sweep time t moves by motion^(t - 1/2), so by half the sweeps' difference
 *  at the sweep's ends. */
double
skewChange(const Pose& a, const Pose& b, const Cloud& points)
{
  float reach = 0.0f;
  for (const auto& p : points)
    reach = std::max(reach, p.getVector3fMap().norm());
  const Pose d = a.inverse() * b;
  const double angle = Eigen::AngleAxisd(Eigen::Matrix3d(d.topLeftCorner<3, 3>())).angle();
  return 0.5 * (d.topRightCorner<3, 1>().norm() + angle * reach);
}
} // namespace

Deskewer::Deskewer(bool enabled, bool clockwise, double voxel_size, unsigned num_threads)
    : enabled_(enabled)
    , clockwise_(clockwise)
    , voxel_size_(voxel_size)
    , num_threads_(num_threads)
{}

Cloud::Ptr
Deskewer::deskew(const Cloud& scan,
                 const std::vector<float>& sweep_times,
                 const Pose& sweep) const
{
  return enabled_ ? deskewSweep(scan, sweep_times, sweep, clockwise_, num_threads_)
                  : Cloud::Ptr(new Cloud(scan));
}

std::vector<float>
Deskewer::sweepTimesOf(const Cloud& scan, const std::vector<float>& sweep_times) const
{
  if (!sweep_times.empty())
    return sweep_times;
  std::vector<float> times(scan.size());
  parallelFor(scan.size(), num_threads_, 4096, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      times[i] = static_cast<float>(sweepTime(scan[i], clockwise_));
  });
  return times;
}

std::pair<Cloud::Ptr, std::vector<float>>
Deskewer::timedSample(const Cloud& scan,
                      const std::vector<float>& times,
                      double voxel_size) const
{
  requireOnePerPoint(scan, times.size(), "Deskewer::timedSample");
  const std::vector<std::uint32_t> kept =
      filters::voxelNearestToCentroidIndices(scan, voxel_size, num_threads_);
  std::pair<Cloud::Ptr, std::vector<float>> out(Cloud::Ptr(new Cloud), std::vector<float>());
  out.first->resize(kept.size());
  out.second.resize(kept.size());
  for (std::size_t k = 0; k < kept.size(); ++k) {
    (*out.first)[k] = scan[kept[k]];
    out.second[k] = times[kept[k]];
  }
  return out;
}

Cloud::Ptr
Deskewer::again(const Cloud& deskewed, const Pose& from, const Pose& to) const
{
  return enabled_ ? redeskew(deskewed, from, to, clockwise_, num_threads_)
                  : Cloud::Ptr(new Cloud(deskewed));
}

void
Deskewer::holdFirst(const Cloud& scan, const std::vector<float>& sweep_times)
{
  if (!enabled_)
    return;
  first_.reset(new Cloud(scan));
  first_times_ = sweep_times;
}

Cloud::Ptr
Deskewer::releaseFirst(const Pose& sweep)
{
  const Cloud::Ptr out = deskew(*first_, first_times_, sweep);
  first_.reset();
  first_times_.clear();
  return out;
}

bool
Deskewer::movesBeyond(const Pose& a, const Pose& b, const Cloud& reduced, double distance)
{
  return skewChange(a, b, reduced) > distance;
}

bool
Deskewer::needsAgain(const Pose& predicted, const Pose& matched, const Cloud& reduced) const
{
  return movesBeyond(predicted, matched, reduced, kRedeskewVoxels * voxel_size_);
}

} // namespace slam
} // namespace pcl_parallel
