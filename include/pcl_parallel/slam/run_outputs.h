/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * A mapped scan directory's files, as `pcl_pslam run` writes them: the poses (3DTK .frames,
 * KITTI, TUM), the map at the final poses (PCD, PLY) and its top view (PNG). Write them into
 * an io::OutputDirectory's path to have them appear as one unit.
 */
#pragma once

#include <pcl_parallel/slam/mapping.h>

#include <cstddef>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace slam {

/** What writeRunOutputs writes beside the poses. */
struct RunOutputOptions {
  double map_voxel = 0.1; ///< map.pcd's voxel (m); 0: every point
  bool ply = false;       ///< also map.ply
  bool picture = true;    ///< map.png
  /** map.png: height, floorplan, occupancy (2D scans) or auto (2D scans: occupancy, else
   *  render::chooseStyle). */
  std::string style = "auto";
  std::vector<std::string> caption; ///< map.png's lines after the run's own
  unsigned num_threads = 0;         ///< 0: all cores
};

/** What writeRunOutputs wrote. */
struct RunOutputs {
  std::vector<std::string> written; ///< the names, in order ("scanNNN.frames" for all of them)
  std::size_t map_points = 0;       ///< points in the map written (map.pcd or this rank's tile)
  std::string picture_style;        ///< the style map.png was drawn in; empty without it
};

/**
 * Writes into `dir`: scanNNN.frames (in the files' units where the scans came in 3DTK's),
 * poses.txt and poses_icp.txt (KITTI), poses_tum.txt and poses_icp_tum.txt (TUM), for a 2D
 * run graph.g2o (VERTEX_SE2 at the final poses, EDGE_SE2 per link: measureLinksSe2), the map of
 * every scan at the final poses (assembleMap) as map.pcd (and map.ply), and map.png with a
 * caption (scans, map points, loops, pLUM iterations, then options.caption). Under MPI
 * (result.spread.ranks > 1) the map is the ranks' tiles (writeMapTile) read back for map.png.
 * progress(stage, done, total) reports "write", "map", "save", "tiles" and "picture" between
 * files; what it throws stops the writing between two complete files.
 */
RunOutputs
writeRunOutputs(const std::string& dir,
                const io::ScanDirectory& scans,
                const MappingResult& result,
                const RunOutputOptions& options,
                const SegmentProgress& progress = {});

/** Under MPI: the map of the scans this rank matched (result.spread.own_begin..own_end) as
 *  map_rank<rank>.pcd (and .ply) in `dir`, a "map" progress step a scan. */
void
writeMapTile(const std::string& dir,
             const io::ScanDirectory& scans,
             const MappingResult& result,
             const RunOutputOptions& options,
             const SegmentProgress& progress = {});

} // namespace slam
} // namespace pcl_parallel
