/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/slam/parameters.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pcl_parallel {
namespace slam {

namespace {

/** The registered sample's voxel, in reduction voxels: KISS-ICP registers a 1.5x coarser
 *  sample than it keeps; ours is coarser still. The front end and the loop pICP share it. */
constexpr double kSourceVoxels = 3.0;
/** 2D scans (Parameters::planar) are lines of a few hundred points: their registered
 *  sample is KISS-ICP's 1.5 voxels, and loops are looked for within 4 median ranges (a
 *  corridor's median range is a metre or two, the drift around a floor's loop more). */
constexpr double kPlanarSourceVoxels = 1.5;
constexpr double kPlanarLoopRanges = 4.0;
/** 2D scans: rounds of linking the revisits that conflict after the last relaxation. */
constexpr int kPlanarRevisitRounds = 3;

/** A length: the user's if set (> 0), else `automatic`. */
double
orAuto(double value, double automatic)
{
  return value > 0.0 ? value : automatic;
}

} // namespace

Parameters
resolve(const Parameters& p, double median_range)
{
  if (!(p.deskew.sweep_period >= 0.0 && std::isfinite(p.deskew.sweep_period)))
    throw std::invalid_argument("DeskewParameters::sweep_period must be zero or positive");
  if (p.planar && !(p.guess.up.head<2>().isZero() && p.guess.up.z() != 0.0))
    throw std::invalid_argument("Parameters::planar: pICP and pLUM move in the x-y plane, so "
                                "guess.up must be z");
  Parameters q = p;
  const double r = orAuto(p.median_range, median_range);
  if (!(r > 0.0 && std::isfinite(r)))
    throw std::invalid_argument("the scans' median range must be positive");
  q.median_range = r;
  ReductionParameters& red = q.reduction;
  red.voxel_size = orAuto(red.voxel_size, r / 20.0);
  const double voxel = red.voxel_size;
  red.source_voxel_size =
      orAuto(red.source_voxel_size, (p.planar ? kPlanarSourceVoxels : kSourceVoxels) * voxel);

  MatcherParameters& m = q.matcher;
  m.normals_from_map = m.normals_from_map || p.planar;
  m.map_voxel_size = orAuto(m.map_voxel_size, 2.0 * voxel);
  // The map reaches as far as the scans (KISS-ICP: max_range): a crop inside it cuts the
  // far walls that pin rotations (docs/design.md, "Local map").
  m.map_distance =
      orAuto(m.map_distance, std::isfinite(red.max_range) ? red.max_range : 5.0 * r);
  m.max_correspondence_distance = orAuto(m.max_correspondence_distance, 10.0 * voxel);
  m.final_correspondence_distance = std::min(
      m.max_correspondence_distance, orAuto(m.final_correspondence_distance, 2.0 * voxel));

  LoopClosureParameters& l = q.loops;
  l.distance = orAuto(l.distance, p.planar ? kPlanarLoopRanges * r : r);
  l.overlap_distance = orAuto(l.overlap_distance, 2.0 * voxel);
  l.icp_distance = orAuto(l.icp_distance, m.max_correspondence_distance);
  if (l.icp_iterations <= 0)
    l.icp_iterations = std::max(m.max_iterations, 50);
  l.icp_epsilon = orAuto(l.icp_epsilon, m.transformation_epsilon);
  l.lum_distance = orAuto(l.lum_distance, 10.0 * voxel);
  l.lum_final_distance = std::min(l.lum_distance, orAuto(l.lum_final_distance, 2.0 * voxel));
  l.lum_epsilon = orAuto(l.lum_epsilon, 0.01 * voxel); // updates far below the sampling
  if (l.revisit_rounds < 0)
    l.revisit_rounds = p.planar ? kPlanarRevisitRounds : 0;
  return q;
}

bool
isResolved(const Parameters& p)
{
  const MatcherParameters& m = p.matcher;
  const LoopClosureParameters& l = p.loops;
  return p.median_range > 0.0 && p.reduction.voxel_size > 0.0 &&
         p.reduction.source_voxel_size > 0.0 && m.map_voxel_size > 0.0 &&
         m.map_distance > 0.0 && m.max_correspondence_distance > 0.0 &&
         m.final_correspondence_distance > 0.0 && l.distance > 0.0 &&
         l.overlap_distance > 0.0 && l.icp_distance > 0.0 && l.icp_iterations > 0 &&
         l.lum_distance > 0.0 && l.lum_final_distance > 0.0 && l.revisit_rounds >= 0;
}

} // namespace slam
} // namespace pcl_parallel
