/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * A map's picture: a top view of the map a person can judge at a glance, drawn with Cairo
 * (antialiased lines, text): the extent from where the points around the trajectory
 * really are, points coloured by height above the trajectory (or floor-plan style), the
 * trajectory, loop-closure links, a scale bar and a caption.
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace pcl_parallel {
namespace render {

/** The map cloud type. */
using Cloud = pcl::PointCloud<pcl::PointXYZ>;
/** The trajectory: one 4x4 pose per scan. */
using Poses = std::vector<Eigen::Matrix4d>;

/** A rectangle in the picture's plane (m). */
struct Extent {
  /** Its lower and upper corners. */
  ///@{
  Eigen::Vector2d lo, hi;
  ///@}
};

/** The part of the plane a picture shows: the box of the trajectory united with the
 *  [quantile, 1 - quantile] range (per axis) of the points within `radius` of a
 *  trajectory position, grown by `margin` of its size on each side. Points farther than
 *  `radius` from every position never count, and the quantiles drop the rest of the
 *  stray returns, so a few far points cannot set the extent (min/max would). Non-finite
 *  points are ignored. Needs a non-empty trajectory. */
Extent
robustExtent(const std::vector<Eigen::Vector2d>& points,
             const std::vector<Eigen::Vector2d>& trajectory,
             double radius = 30.0,
             double quantile = 0.005,
             double margin = 0.04);

/** How writeMapPicture draws the map. */
struct PictureOptions {
  int up = 2; ///< vertical axis (0 x, 1 y, 2 z); the view looks down it
  /** height, floorplan, occupancy (needs `scans`) or auto (occupancy with scans, else
   *  chooseStyle). */
  std::string style = "auto";
  /** For the occupancy style (2D scans): each trajectory pose's scan in its scanner frame.
   *  Per cell, the share of the rays reaching it that end there: walls dark, free space
   *  light, cells no ray reached grey. */
  std::vector<Cloud::ConstPtr> scans;
  int size = 1400;      ///< pixels on the long side of the map area
  double radius = 30.0; ///< metres, for robustExtent
  double cell = 0.1;    ///< metres: points fill cells of this size (the map's voxel)
  std::vector<std::string> caption;                           ///< lines under the map
  std::vector<std::pair<std::uint32_t, std::uint32_t>> loops; ///< drawn as links
  unsigned num_threads = 0; ///< for the per-point passes; 0: all cores
};

/** Writes the PNG (map and trajectory in metres) under a temporary name, then renamed (io::
 *  writeAtomically). Returns the style used ("height", "floorplan" or "occupancy"). Throws
 *  std::invalid_argument for the occupancy style without a scan per pose, and
 *  std::runtime_error naming the file when it cannot be written. */
std::string
writeMapPicture(const std::string& path,
                const Cloud& map,
                const Poses& trajectory,
                const PictureOptions& options);

/** "floorplan" when most poses see a ceiling (at least 20 map points 0.3-6 m above them
 *  within 1 m horizontally: a patch of surface, not a stray return), else "height". */
std::string
chooseStyle(const Cloud& map, const Poses& trajectory, int up, unsigned num_threads = 0);

/** Cairo's version, for report.json. */
std::string
cairoVersion();

} // namespace render
} // namespace pcl_parallel
