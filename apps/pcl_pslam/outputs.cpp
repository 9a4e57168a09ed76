/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "outputs.h"

#include <pcl_parallel/evaluation/report.h>
#include <pcl_parallel/io/atomic_write.h>
#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/render/map_picture.h>

#include <pcl/pcl_config.h>

#include <boost/version.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>

#ifndef PCL_PSLAM_VERSION
#define PCL_PSLAM_VERSION "unknown"
#endif

namespace fs = std::filesystem;
namespace ev = pcl_parallel::evaluation;
using nlohmann::json;

namespace pcl_pslam {

namespace {

std::string
join(const std::string& dir, const std::string& name)
{
  return (fs::path(dir) / name).string();
}

/** A rank's part of the map under MPI. */
std::string
mapTileName(int rank, const char* extension)
{
  return "map_rank" + std::to_string(rank) + extension;
}

/** The map of scans [begin, end) at the final poses (slam::assembleMap, deskewed as the
 *  run's resolved parameters say), a progress step a scan. */
Cloud::Ptr
buildMap(const Options& o,
         const Input& in,
         const Result& r,
         ProgressReporter& progress,
         std::size_t begin = 0,
         std::size_t end = std::size_t(-1))
{
  return pcl_parallel::slam::assembleMap(
      in,
      r.final,
      r.parameters,
      mapVoxel(o, in.scale),
      [&](int done, int total) { progress.update("map", done, total); },
      begin,
      end);
}

/** The odometry's (where the run had one), the front end's and the final poses' errors
 *  against the simulation's truth: the console, map.png and report.json give the same. */
std::vector<ev::NamedEvaluation>
truthErrors(const Input& in, const Result& r)
{
  std::vector<ev::NamedEvaluation> rows;
  if (in.odometry)
    rows.push_back({"odometry", ev::evaluateTrajectory(in.initial, in.truth)});
  rows.push_back({"front end", ev::evaluateTrajectory(r.icp, in.truth)});
  rows.push_back({"final", ev::evaluateTrajectory(r.final, in.truth)});
  return rows;
}

} // namespace

std::unique_ptr<pcl_parallel::io::OutputDirectory>
openOutputDirectory(const std::string& dir)
{
  try {
    return std::make_unique<pcl_parallel::io::OutputDirectory>(
        dir, pcl_parallel::io::isRunOutputName);
  }
  catch (const pcl_parallel::io::OutputDirectoryError& e) {
    throw UsageError(std::string("--out ") + e.what());
  }
}

void
writeMapTile(const Options& o,
             const std::string& dir,
             const Input& in,
             const Result& r,
             ProgressReporter& progress)
{
  const Cloud::Ptr map = buildMap(o, in, r, progress, r.spread.own_begin, r.spread.own_end);
  pcl_parallel::io::writePcdScan(join(dir, mapTileName(r.spread.rank, ".pcd")), *map);
  if (o.ply)
    pcl_parallel::io::writePlyScan(join(dir, mapTileName(r.spread.rank, ".ply")), *map);
}

void
printTruthErrors(std::ostream& out, const Input& in, const Result& r)
{
  const auto lengths = ev::kittiLengthsFor(in.truth);
  out << "errors against the simulation's truth (ATE after SE(3) alignment; RPE as the KITTI "
         "devkit, over "
      << lengths.front() << ".." << lengths.back() << " m):\n";
  ev::printErrorRows(out, truthErrors(in, r));
}

namespace {

/** scanNNN.frames (3DTK's units for data that came in them), KITTI and TUM poses. */
void
writePoseFiles(const std::string& dir,
               const Input& in,
               const Result& r,
               ProgressReporter& progress,
               std::vector<std::string>& written)
{
  const double frames_scale = in.frames_3dtk ? in.scale : 1.0; // uos: cm
  progress.update("write", 0, 1);
  const auto names = pcl_parallel::io::writeRunPoses(
      dir, in.numbers, in.initial, r.icp, r.final, in.stamps, frames_scale, [&] {
        progress.update("write", 0, 1); // a signal stops between two complete files
      });
  written.insert(written.end(), names.begin(), names.end());
  progress.update("write", 1, 1);
}

/** map.pcd (and map.ply) at the final poses; under MPI the tiles the ranks wrote, read
 *  back for the picture. Returns the map. */
Cloud::Ptr
writeMap(const Options& o,
         const std::string& dir,
         const Input& in,
         const Result& r,
         ProgressReporter& progress,
         std::vector<std::string>& written)
{
  Cloud::Ptr map(new Cloud);
  if (r.spread.ranks > 1) { // the tiles every rank wrote (writeMapTile)
    for (int k = 0; k < r.spread.ranks; ++k) {
      progress.update("tiles", k, r.spread.ranks);
      *map += *pcl_parallel::io::loadPcdScan(join(dir, mapTileName(k, ".pcd")));
    }
    written.push_back(mapTileName(0, ".pcd") + ".." + mapTileName(r.spread.ranks - 1, ".pcd"));
    if (o.ply)
      written.push_back(mapTileName(0, ".ply") + ".." +
                        mapTileName(r.spread.ranks - 1, ".ply"));
    progress.update("tiles", r.spread.ranks, r.spread.ranks);
    return map;
  }
  progress.update("map", 0, 1);
  map = buildMap(o, in, r, progress);
  progress.update("save", 0, 1);
  pcl_parallel::io::writePcdScan(join(dir, "map.pcd"), *map);
  written.push_back("map.pcd");
  if (o.ply) {
    progress.update("save", 0, 1);
    pcl_parallel::io::writePlyScan(join(dir, "map.ply"), *map);
    written.push_back("map.ply");
  }
  progress.update("save", 1, 1);
  return map;
}

/** map.png with its caption; returns the style it was drawn in. */
std::string
writePicture(const Options& o,
             const std::string& dir,
             const Input& in,
             const Result& r,
             const Cloud& map,
             ProgressReporter& progress,
             std::vector<std::string>& written)
{
  progress.update("picture", 0, 1);
  const double map_voxel = mapVoxel(o, in.scale);
  pcl_parallel::render::PictureOptions po;
  po.up = in.up;
  po.style = o.style;
  po.cell = map_voxel > 0.0 ? map_voxel : 0.05;
  po.loops = pcl_parallel::slam::loopLinks(r);
  po.num_threads = o.threads;
  char line[256];
  std::snprintf(line,
                sizeof line,
                "%zu scans, %zu map points (%.2f m voxels), %zu loop link%s, pLUM %d "
                "iteration%s",
                in.size(),
                map.size(),
                map_voxel,
                po.loops.size(),
                po.loops.size() == 1 ? "" : "s",
                r.lum_iterations,
                r.lum_iterations == 1 ? "" : "s");
  po.caption.push_back(line);
  if (!in.truth.empty()) {
    std::string errors = "ATE against the truth (SE(3)-aligned):";
    for (const auto& row : truthErrors(in, r)) {
      std::snprintf(
          line, sizeof line, " %s %.3f m,", row.name.c_str(), row.errors.ate.translation.rmse);
      errors += line;
    }
    errors.pop_back();
    po.caption.push_back(errors);
  }
  po.caption.push_back(o.command == "demo" ? "pcl_pslam demo" : "pcl_pslam run " + o.dir);
  const std::string style =
      pcl_parallel::render::writeMapPicture(join(dir, "map.png"), map, r.final, po);
  written.push_back("map.png");
  progress.update("picture", 1, 1);
  return style;
}

json
versionsJson()
{
  const auto version = [](int major, int minor, int patch) {
    return std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(patch);
  };
  return {{"pcl_pslam", PCL_PSLAM_VERSION},
          {"pcl", PCL_VERSION_PRETTY},
          {"eigen", version(EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION)},
          {"boost", BOOST_LIB_VERSION},
          {"cairo", pcl_parallel::render::cairoVersion()},
          {"nlohmann_json",
           version(NLOHMANN_JSON_VERSION_MAJOR,
                   NLOHMANN_JSON_VERSION_MINOR,
                   NLOHMANN_JSON_VERSION_PATCH)},
          {"compiler", __VERSION__}};
}

json
inputJson(const Options& o, const Input& in, const Result& r)
{
  return {
      {"command", o.command},
      {"directory", o.dir},
      {"format", in.format},
      {"scans", in.size()},
      {"scale_to_metres", in.scale},
      {"odometry", in.odometry},
      {"poses_file", o.poses_file},
      {"timestamps", in.has_stamps},
      {"scans_with_point_times", // counted where read (rank 0 alone under MPI), with --deskew
       r.spread.ranks > 1 || !o.deskew ? json(nullptr) : json(in.reading.timed_scans)},
      {"first", o.first},
      {"last", o.last},
      {"min_range", o.min_range},
      {"max_range", std::isfinite(o.max_range) ? json(o.max_range) : json(nullptr)}};
}

/** report.json: what was run, with what, and what each stage did and took; the caller
 *  adds what was written. */
json
reportJson(const Options& o, const Input& in, const Result& r, const ProgressReporter& progress)
{
  json j = json::parse(pcl_parallel::slam::toJson(r, in, in.reading));
  j["parameters"]["map_voxel_m"] = mapVoxel(o, in.scale);
  j.update({{"program", "pcl_pslam"},
            {"versions", versionsJson()},
            {"threads", pcl_parallel::resolveNumberOfThreads(o.threads)},
            {"input", inputJson(o, in, r)},
            {"stages", json::array()},
            {"total_seconds", progress.elapsed()}});
  for (const auto& s : progress.stages())
    j["stages"].push_back({{"name", s.name}, {"seconds", s.seconds}, {"steps", s.steps}});
  if (!in.truth.empty())
    for (auto [key, e] : truthErrors(in, r)) {
      std::replace(key.begin(), key.end(), ' ', '_'); // "front end": front_end
      j["errors_against_truth"][key] = {{"ate_m", e.ate.translation.rmse},
                                        {"ate_deg", e.ate.rotation_deg.rmse},
                                        {"kitti_rpe_percent", e.kitti.translation_percent},
                                        {"kitti_rpe_deg_per_m", e.kitti.rotation_deg_per_m},
                                        {"frame_rpe_m", e.rpe.translation.rmse}};
    }
  return j;
}

} // namespace

std::vector<std::string>
writeOutputs(const Options& o,
             const std::string& dir,
             const Input& in,
             const Result& r,
             ProgressReporter& progress,
             const std::string& command_line)
{
  std::vector<std::string> written;
  writePoseFiles(dir, in, r, progress, written);
  const Cloud::Ptr map = writeMap(o, dir, in, r, progress, written);
  const std::string style =
      o.picture ? writePicture(o, dir, in, r, *map, progress, written) : "";
  progress.update("report", 0, 1);
  progress.finish();
  json j = reportJson(o, in, r, progress);
  j["command_line"] = command_line;
  j["map"] = {{"points", map->size()}, {"voxel_m", mapVoxel(o, in.scale)}};
  if (!style.empty())
    j["picture_style"] = style;
  j["outputs"] = written;
  pcl_parallel::io::writeStreamAtomically(join(dir, "report.json"), [&](std::ostream& out) {
    out << j.dump(2, ' ', false, json::error_handler_t::replace) << '\n';
  });
  written.push_back("report.json");
  return written;
}

namespace {

/** Warnings about the run's results: on stdout where the user should look, on stderr
 *  where the input is likely wrong. */
void
printFindings(const Input& in, const Result& r)
{
  // Matches the pose search placed came from nothing but the scans: right on a distinct
  // site, possibly a room or corridor away where the site repeats.
  if (r.pose_search_won > 0)
    std::printf("pose search: %zu of %zu matches searched (no initial poses), %zu placed by "
                "it; where the site repeats (rooms, corridors) check them in map.png, or "
                "give --poses\n",
                r.pose_searched,
                in.size() - 1,
                r.pose_search_won);
  // Odometry the scans contradict step after step is in another frame, or broken.
  if (r.odometry_disagreement &&
      *r.odometry_disagreement > pcl_parallel::slam::kOdometryDisagreementLimit)
    std::fprintf(stderr,
                 "pcl_pslam: warning: pICP moved the scans %.2f times as far from the "
                 "odometry's steps as the steps are long (median of the first %zu steps): "
                 "is the odometry in the scanner's frame? (KITTI's poses.txt is the left "
                 "camera's: apply calib.txt's Tr.) Without it the front end predicts by "
                 "constant velocity\n",
                 *r.odometry_disagreement,
                 pcl_parallel::slam::kOdometryDisagreementSteps);
  const std::vector<std::size_t> notable = pcl_parallel::slam::notableSequenceSteps(r);
  if (!notable.empty()) {
    std::string worst;
    for (std::size_t k = 0; k < notable.size() && k < 3; ++k)
      worst += (k ? ", " : "") + std::to_string(in.numbers[notable[k]]) + " (chi2 " +
               std::to_string(std::lround(r.reports[notable[k]].sequence_chi2)) + ")";
    std::printf("loop closing disagreed most with the front end's steps to scans %s; "
                "report.json: sequence_chi2\n",
                worst.c_str());
  }
}

} // namespace

void
printSummary(const Options& o,
             const Input& in,
             const Result& r,
             const std::vector<std::string>& written,
             bool replaced,
             double seconds)
{
  if (r.icp_failures > 0)
    std::printf("pICP: %d of %zu matches did not converge; their initial steps were kept\n",
                r.icp_failures,
                in.size() - 1);
  std::printf("pLUM: %zu loop link%s beside the %zu consecutive ones, %d iteration%s\n",
              r.links.size(),
              r.links.size() == 1 ? "" : "s",
              in.size() - 1,
              r.lum_iterations,
              r.lum_iterations == 1 ? "" : "s");
  printFindings(in, r);
  if (!o.quiet) {
    const auto& t = r.times;
    std::printf("%s: front end %.2f s, loop detection %.2f s, loop closing %.2f s "
                "(%d pLUM run%s); %.1f ms per scan; %zu bytes kept per scan\n",
                r.spread.ranks > 1
                    ? "rank 0's stage times (its segments, then the whole sequence)"
                    : "stage times",
                t.preprocess + t.front_end,
                t.loop_detection,
                t.loop_closing,
                r.relaxations,
                r.relaxations == 1 ? "" : "s",
                1e3 * t.total() / static_cast<double>(in.size()),
                r.bytes_per_scan);
  }
  if (!in.truth.empty())
    printTruthErrors(std::cout, in, r);
  std::string names;
  for (const auto& w : written)
    names += (names.empty() ? "" : ", ") + w;
  std::printf("wrote %s/{%s} in %.1f s%s\n",
              o.out.c_str(),
              names.c_str(),
              seconds,
              replaced ? ", replacing an earlier run's outputs" : "");
}

} // namespace pcl_pslam
