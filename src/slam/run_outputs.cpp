/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/io/g2o.h>
#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/io/scan_directory.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/render/map_picture.h>
#include <pcl_parallel/slam/pose_graph_se2.h>
#include <pcl_parallel/slam/run_outputs.h>

#include <cstdio>
#include <filesystem>

namespace pcl_parallel {
namespace slam {

namespace {

std::string
join(const std::string& dir, const std::string& name)
{
  return (std::filesystem::path(dir) / name).string();
}

/** A rank's part of the map under MPI. */
std::string
tileName(int rank, const char* extension)
{
  return "map_rank" + std::to_string(rank) + extension;
}

void
report(const SegmentProgress& progress, const char* stage, std::size_t done, std::size_t total)
{
  if (progress)
    progress(stage, done, total);
}

/** The map of scans [begin, end) at the final poses, a "map" step a scan. */
Cloud::Ptr
mapOf(const io::ScanDirectory& scans,
      const MappingResult& r,
      const RunOutputOptions& o,
      const SegmentProgress& progress,
      std::size_t begin = 0,
      std::size_t end = std::size_t(-1))
{
  Parameters params = r.parameters;
  params.num_threads = o.num_threads;
  return assembleMap(
      scans,
      r.final,
      params,
      o.map_voxel,
      [&](int done, int total) { report(progress, "map", done, total); },
      begin,
      end);
}

/** map.pcd (and map.ply); under MPI the tiles every rank wrote, read back. */
Cloud::Ptr
writeMap(const std::string& dir,
         const io::ScanDirectory& scans,
         const MappingResult& r,
         const RunOutputOptions& o,
         const SegmentProgress& progress,
         std::vector<std::string>& written)
{
  const int ranks = r.spread.ranks;
  Cloud::Ptr map(new Cloud);
  if (ranks > 1) {
    for (int k = 0; k < ranks; ++k) {
      report(progress, "tiles", k, ranks);
      *map += *io::loadPcdScan(join(dir, tileName(k, ".pcd")));
    }
    written.push_back(tileName(0, ".pcd") + ".." + tileName(ranks - 1, ".pcd"));
    if (o.ply)
      written.push_back(tileName(0, ".ply") + ".." + tileName(ranks - 1, ".ply"));
    report(progress, "tiles", ranks, ranks);
    return map;
  }
  report(progress, "map", 0, 1);
  map = mapOf(scans, r, o, progress);
  report(progress, "save", 0, 1);
  io::writePcdScan(join(dir, "map.pcd"), *map);
  written.push_back("map.pcd");
  if (o.ply) {
    report(progress, "save", 0, 1);
    io::writePlyScan(join(dir, "map.ply"), *map);
    written.push_back("map.ply");
  }
  report(progress, "save", 1, 1);
  return map;
}

/** map.png: the map and the trajectory from above, the run's line first in the caption. */
std::string
writePicture(const std::string& dir,
             const io::ScanDirectory& scans,
             const MappingResult& r,
             const RunOutputOptions& o,
             const Cloud& map)
{
  render::PictureOptions po;
  po.up = scans.up;
  po.style = o.style;
  po.cell = o.map_voxel > 0.0 ? o.map_voxel : 0.05;
  po.loops = loopLinks(r);
  po.num_threads = o.num_threads;
  if ((r.parameters.planar && o.style == "auto") || o.style == "occupancy")
    for (std::size_t k = 0; k < scans.size(); ++k) // the occupancy style's rays
      po.scans.push_back(io::readScan(scans, k));
  char line[256];
  std::snprintf(line,
                sizeof line,
                "%zu scans, %zu map points (%.2f m voxels), %zu loop link%s, pLUM %d "
                "iteration%s",
                scans.size(),
                map.size(),
                o.map_voxel,
                po.loops.size(),
                po.loops.size() == 1 ? "" : "s",
                r.lum_iterations,
                r.lum_iterations == 1 ? "" : "s");
  po.caption.push_back(line);
  po.caption.insert(po.caption.end(), o.caption.begin(), o.caption.end());
  return render::writeMapPicture(join(dir, "map.png"), map, r.final, po);
}

} // namespace

RunOutputs
writeRunOutputs(const std::string& dir,
                const io::ScanDirectory& scans,
                const MappingResult& result,
                const RunOutputOptions& options,
                const SegmentProgress& progress)
{
  RunOutputs out;
  report(progress, "write", 0, 1);
  const double frames_scale = scans.frames_3dtk ? scans.scale : 1.0; // uos: cm
  out.written =
      io::writeRunPoses(dir,
                        scans.numbers,
                        scans.initial,
                        result.icp,
                        result.final,
                        scans.stamps,
                        frames_scale,
                        [&] {
                          report(progress, "write", 0, 1); // a stop between two complete files
                        });
  if (result.parameters.planar) { // 2D: the pose graph for g2o
    io::writeG2oSe2(join(dir, "graph.g2o"), result.final, measureLinksSe2(scans, result));
    out.written.push_back("graph.g2o");
  }
  report(progress, "write", 1, 1);
  const Cloud::Ptr map = writeMap(dir, scans, result, options, progress, out.written);
  out.map_points = map->size();
  if (options.picture) {
    report(progress, "picture", 0, 1);
    out.picture_style = writePicture(dir, scans, result, options, *map);
    out.written.push_back("map.png");
    report(progress, "picture", 1, 1);
  }
  return out;
}

void
writeMapTile(const std::string& dir,
             const io::ScanDirectory& scans,
             const MappingResult& result,
             const RunOutputOptions& options,
             const SegmentProgress& progress)
{
  const Cloud::Ptr map =
      mapOf(scans, result, options, progress, result.spread.own_begin, result.spread.own_end);
  io::writePcdScan(join(dir, tileName(result.spread.rank, ".pcd")), *map);
  if (options.ply)
    io::writePlyScan(join(dir, tileName(result.spread.rank, ".ply")), *map);
}

} // namespace slam
} // namespace pcl_parallel
