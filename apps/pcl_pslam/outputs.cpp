/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "outputs.h"

#include <pcl_parallel/evaluation/trajectory_error.h>
#include <pcl_parallel/io/atomic_write.h>
#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/render/map_picture.h>

#include <pcl/pcl_config.h>

#include <Eigen/Geometry>
#include <boost/version.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <unistd.h>

#ifndef PCL_PSLAM_VERSION
#define PCL_PSLAM_VERSION "unknown"
#endif

namespace fs = std::filesystem;

namespace pcl_pslam {

namespace {

std::string
join(const std::string& dir, const std::string& name)
{
  return (fs::path(dir) / name).string();
}

} // namespace

bool
prepareOutputDirectory(const std::string& dir)
{
  std::error_code ec;
  const bool existed = fs::exists(dir, ec);
  if (existed && !fs::is_directory(dir, ec))
    throw UsageError(dir + ": --out exists and is not a directory");
  if (!existed && !fs::create_directories(dir, ec))
    throw UsageError(dir + ": cannot create the output directory (" + ec.message() + ")");
  const std::string probe = join(dir, ".pcl_pslam_probe." + std::to_string(::getpid()));
  {
    std::ofstream f(probe);
    if (!(f << "probe\n")) {
      fs::remove(probe, ec);
      if (!existed)
        fs::remove(dir, ec);
      throw UsageError(dir + ": the output directory is not writable");
    }
  }
  fs::remove(probe, ec);
  return !existed;
}

void
writeScanFrames(const std::string& path,
                const Eigen::Matrix4d& initial,
                const Eigen::Matrix4d& icp,
                const Eigen::Matrix4d& final_pose,
                bool fixed,
                double scale)
{
  namespace io = pcl_parallel::io;
  constexpr int kDigits = 12;
  const std::vector<io::Frame> frames = {
      {initial, io::kFramesInvalid},
      {icp, fixed ? io::kFramesIcpInactive : io::kFramesIcp},
      {final_pose, fixed ? io::kFramesIcpInactive : io::kFramesLum}};
  io::writeFrames(path, frames, scale, kDigits);
}

namespace {

/** How the map pass reads scan k of `in`: again, and with --deskew deskewed by the motion
 *  at its final pose (slam::mapFrame), on `threads` threads. Set up once per map. */
class MapScans {
public:
  MapScans(const Options& o, const Input& in, const Poses& poses)
      : in_(in)
      , poses_(poses)
      , params_(toParameters(o, in.scale))
      , stamps_(in.has_stamps ? in.stamps : std::vector<double>())
  {}

  Cloud::Ptr
  read(std::size_t k, unsigned threads) const
  {
    if (!params_.deskew.enabled)
      return readScan(in_, k);
    std::vector<double> point_times;
    const Cloud::Ptr scan = readScan(in_, k, &point_times);
    pcl_parallel::slam::Parameters p = params_;
    p.num_threads = threads;
    return pcl_parallel::slam::mapFrame(*scan, point_times, poses_, stamps_, k, p);
  }

private:
  const Input& in_;
  const Poses& poses_;
  pcl_parallel::slam::Parameters params_;
  std::vector<double> stamps_; ///< the scans' time stamps, or none
};

} // namespace

Cloud::Ptr
buildMap(const Options& o,
         const Input& in,
         const Poses& poses,
         double voxel_size,
         const std::function<void(int, int)>& step,
         std::size_t begin,
         std::size_t end)
{
  const MapScans scans(o, in, poses);
  return pcl_parallel::slam::assembleMap(
      [&](std::size_t k, unsigned threads) { return scans.read(k, threads); },
      poses,
      begin,
      std::min(end, in.size()),
      voxel_size,
      o.threads,
      step);
}

std::string
mapTileName(int rank, const char* extension)
{
  return "map_rank" + std::to_string(rank) + extension;
}

void
writeMapTile(const Options& o, const Input& in, const Result& r, ProgressReporter& progress)
{
  const Cloud::Ptr map = buildMap(
      o,
      in,
      r.final,
      mapVoxel(o, in.scale),
      [&](int done, int total) { progress.update("map", done, total); },
      r.spread.own_begin,
      r.spread.own_end);
  pcl_parallel::io::writePcdScan(join(o.out, mapTileName(r.spread.rank, ".pcd")), *map);
  if (o.ply)
    pcl_parallel::io::writePlyScan(join(o.out, mapTileName(r.spread.rank, ".ply")), *map);
}

namespace {

/** One row of errors against the simulation's truth: the console, map.png and
 *  report.json give the same numbers. */
struct TruthRow {
  const char* name; ///< console and picture
  const char* key;  ///< report.json
  pcl_parallel::evaluation::TrajectoryEvaluation errors;
};

/** The odometry's (where the run had one), the front end's and the final poses' errors
 *  (ATE after SE(3) alignment, KITTI-style RPE, per-frame RPE). */
std::vector<TruthRow>
truthErrors(const Input& in, const Result& r)
{
  namespace ev = pcl_parallel::evaluation;
  std::vector<TruthRow> rows;
  if (in.odometry)
    rows.push_back({"odometry", "odometry", ev::evaluateTrajectory(in.initial, in.truth)});
  rows.push_back({"front end", "front_end", ev::evaluateTrajectory(r.icp, in.truth)});
  rows.push_back({"final", "final", ev::evaluateTrajectory(r.final, in.truth)});
  return rows;
}

} // namespace

void
printTruthErrors(std::ostream& out, const Input& in, const Result& r)
{
  namespace ev = pcl_parallel::evaluation;
  char line[200];
  out << "errors against the simulation's truth (ATE after SE(3) alignment; RPE as the KITTI "
         "devkit, over "
      << ev::kittiLengthsFor(in.truth).front() << ".." << ev::kittiLengthsFor(in.truth).back()
      << " m):\n";
  std::snprintf(line,
                sizeof line,
                "  %-10s %10s %10s %9s %10s %12s\n",
                "",
                "ATE [m]",
                "ATE [deg]",
                "RPE [%]",
                "RPE [deg/m]",
                "frame RPE [m]");
  out << line;
  for (const auto& row : truthErrors(in, r)) {
    const auto& e = row.errors;
    std::snprintf(line,
                  sizeof line,
                  "  %-10s %10.4f %10.3f %9.3f %10.5f %12.4f\n",
                  row.name,
                  e.ate.translation.rmse,
                  e.ate.rotation_deg.rmse,
                  e.kitti.translation_percent,
                  e.kitti.rotation_deg_per_m,
                  e.rpe.translation.rmse);
    out << line;
  }
}

namespace {

/** scanNNN.frames (3DTK's units for data that came in them), then the KITTI and TUM pose
 *  files of the front end and the final poses. */
void
writePoseFiles(const Options& o,
               const Input& in,
               const Result& r,
               ProgressReporter& progress,
               std::vector<std::string>& written)
{
  const double frames_scale = in.frames_3dtk ? in.scale : 1.0; // uos: cm
  progress.update("write", 0, 1);
  for (std::size_t i = 0; i < in.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "scan%03d.frames", in.numbers[i]);
    writeScanFrames(
        join(o.out, name), in.initial[i], r.icp[i], r.final[i], i == 0, frames_scale);
    progress.update("write", 0, 1); // a signal stops between two complete files
  }
  written.push_back("scanNNN.frames");
  // The io writers are atomic (temporary name, rename) and name the file on failure.
  namespace io = pcl_parallel::io;
  io::writeKittiPoses(join(o.out, "poses.txt"), r.final);
  io::writeKittiPoses(join(o.out, "poses_icp.txt"), r.icp);
  io::writeTumTrajectory(join(o.out, "poses_tum.txt"), r.final, in.stamps);
  io::writeTumTrajectory(join(o.out, "poses_icp_tum.txt"), r.icp, in.stamps);
  written.insert(written.end(),
                 {"poses.txt", "poses_icp.txt", "poses_tum.txt", "poses_icp_tum.txt"});
  progress.update("write", 1, 1);
}

/** map.pcd (and map.ply) at the final poses; under MPI the tiles the ranks wrote, read
 *  back for the picture. Returns the map. */
Cloud::Ptr
writeMap(const Options& o,
         const Input& in,
         const Result& r,
         double map_voxel,
         ProgressReporter& progress,
         std::vector<std::string>& written)
{
  Cloud::Ptr map(new Cloud);
  if (r.spread.ranks > 1) { // the tiles every rank wrote (writeMapTile)
    for (int k = 0; k < r.spread.ranks; ++k) {
      progress.update("tiles", k, r.spread.ranks);
      *map += *pcl_parallel::io::loadPcdScan(join(o.out, mapTileName(k, ".pcd")));
    }
    written.push_back(mapTileName(0, ".pcd") + ".." + mapTileName(r.spread.ranks - 1, ".pcd"));
    if (o.ply)
      written.push_back(mapTileName(0, ".ply") + ".." +
                        mapTileName(r.spread.ranks - 1, ".ply"));
    progress.update("tiles", r.spread.ranks, r.spread.ranks);
    return map;
  }
  progress.update("map", 0, 1);
  map = buildMap(o, in, r.final, map_voxel, [&](int done, int total) {
    progress.update("map", done, total);
  });
  progress.update("save", 0, 1);
  pcl_parallel::io::writePcdScan(join(o.out, "map.pcd"), *map);
  written.push_back("map.pcd");
  if (o.ply) {
    progress.update("save", 0, 1);
    pcl_parallel::io::writePlyScan(join(o.out, "map.ply"), *map);
    written.push_back("map.ply");
  }
  progress.update("save", 1, 1);
  return map;
}

/** map.png with its caption; returns the style it was drawn in. */
std::string
writePicture(const Options& o,
             const Input& in,
             const Result& r,
             const Cloud& map,
             double map_voxel,
             const std::vector<std::pair<std::uint32_t, std::uint32_t>>& loops,
             ProgressReporter& progress,
             std::vector<std::string>& written)
{
  progress.update("picture", 0, 1);
  pcl_parallel::render::PictureOptions po;
  po.up = in.up;
  po.style = o.style;
  po.cell = map_voxel > 0.0 ? map_voxel : 0.05;
  po.loops = loops;
  po.num_threads = o.threads;
  char line[256];
  std::snprintf(line,
                sizeof line,
                "%zu scans, %zu map points (%.2f m voxels), %zu loop link%s, pLUM %d "
                "iteration%s",
                in.size(),
                map.size(),
                map_voxel,
                loops.size(),
                loops.size() == 1 ? "" : "s",
                r.lum_iterations,
                r.lum_iterations == 1 ? "" : "s");
  po.caption.push_back(line);
  if (!in.truth.empty()) {
    std::string errors = "ATE against the truth (SE(3)-aligned):";
    for (const auto& row : truthErrors(in, r)) {
      std::snprintf(
          line, sizeof line, " %s %.3f m,", row.name, row.errors.ate.translation.rmse);
      errors += line;
    }
    errors.pop_back();
    po.caption.push_back(errors);
  }
  po.caption.push_back(o.command == "demo" ? "pcl_pslam demo" : "pcl_pslam run " + o.dir);
  std::string style;
  pcl_parallel::io::writeAtomically(join(o.out, "map.png"), [&](const std::string& tmp) {
    style = pcl_parallel::render::writeMapPicture(tmp, map, r.final, po);
  });
  written.push_back("map.png");
  progress.update("picture", 1, 1);
  return style;
}

nlohmann::json
versionsJson()
{
  return {{"pcl_pslam", PCL_PSLAM_VERSION},
          {"pcl", PCL_VERSION_PRETTY},
          {"eigen",
           std::to_string(EIGEN_WORLD_VERSION) + "." + std::to_string(EIGEN_MAJOR_VERSION) +
               "." + std::to_string(EIGEN_MINOR_VERSION)},
          {"boost", BOOST_LIB_VERSION},
          {"cairo", pcl_parallel::render::cairoVersion()},
          {"nlohmann_json",
           std::to_string(NLOHMANN_JSON_VERSION_MAJOR) + "." +
               std::to_string(NLOHMANN_JSON_VERSION_MINOR) + "." +
               std::to_string(NLOHMANN_JSON_VERSION_PATCH)},
          {"compiler", __VERSION__}};
}

nlohmann::json
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
       r.spread.ranks > 1 || !o.deskew ? nlohmann::json(nullptr)
                                       : nlohmann::json(in.timed_scans)},
      {"first", o.first},
      {"last", o.last},
      {"min_range", o.min_range},
      {"max_range",
       std::isfinite(o.max_range) ? nlohmann::json(o.max_range) : nlohmann::json(nullptr)}};
}

/** The parameters as the pipeline resolved them (automatic lengths from the data). */
nlohmann::json
parametersJson(const Result& r, double map_voxel)
{
  const pcl_parallel::slam::Parameters& p = r.parameters;
  const auto& m = p.matcher;
  const auto& l = p.loops;
  const Eigen::Vector3d& up = p.guess.up;
  return {{"voxel_size_m", p.reduction.voxel_size},
          {"source_voxel_size_m", p.reduction.source_voxel_size},
          {"map_voxel_size_m", m.map_voxel_size},
          {"map_distance_m", m.map_distance},
          {"icp_distance_m", m.max_correspondence_distance},
          {"icp_final_distance_m", m.final_correspondence_distance},
          {"icp_adaptive_threshold", m.adaptive_threshold},
          {"icp_point_to_plane", m.point_to_plane},
          {"icp_iterations", m.max_iterations},
          {"icp_epsilon", m.transformation_epsilon},
          {"loop_distance_m", l.distance},
          {"loop_size", l.min_separation},
          {"loop_min_overlap", l.min_overlap},
          {"lum_distance_m", l.lum_distance},
          {"lum_final_distance_m", l.lum_final_distance},
          {"lum_iterations", l.lum_iterations},
          {"lum_iterations_per_loop", l.lum_iterations_per_loop},
          {"lum_epsilon", l.lum_epsilon},
          {"lum_sequence_constraints", l.sequence_constraints},
          {"elch", l.distribute_error},
          {"map_voxel_m", map_voxel},
          {"scan_to_scan", m.target == pcl_parallel::slam::MatchTarget::kPreviousScan},
          {"deskew", p.deskew.enabled},
          {"sweep_period_s", p.deskew.sweep_period},
          {"sweep_clockwise", p.deskew.sweep_clockwise},
          {"pose_search", p.guess.pose_search},
          {"up", std::vector<double>{up.x(), up.y(), up.z()}},
          {"close_loops", l.enabled}};
}

/** How many matches the pose search ran for, and how many it placed. */
std::pair<std::size_t, std::size_t>
poseSearches(const std::vector<pcl_parallel::slam::ScanReport>& reports)
{
  std::size_t searched = 0, found = 0;
  for (const auto& rep : reports) {
    searched += rep.pose_searched ? 1 : 0;
    found += std::isfinite(rep.start_heading) ? 1 : 0;
  }
  return {searched, found};
}

/** Per scan: what it was, what the front end did with it, the loop pairs tried. */
nlohmann::json
scansJson(const Input& in, const Result& r)
{
  nlohmann::json scans = nlohmann::json::array();
  for (std::size_t i = 0; i < in.size(); ++i) {
    const auto& rep = r.reports.at(i); // one per scan
    nlohmann::json s = {{"index", i},
                        {"number", in.numbers[i]},
                        {"stamp", in.stamps[i]},
                        {"points", rep.points},
                        {"points_reduced", rep.reduced_points}};
    s["icp_converged"] = rep.converged;
    s["icp_fitness"] = rep.fitness;
    s["icp_gate"] = rep.gate;
    s["icp_correction"] = rep.correction;
    s["icp_start_offset"] = rep.start_offset;
    s["icp_start_turn"] = rep.start_turn;
    s["pose_searched"] = rep.pose_searched;
    s["deskewed_again"] = rep.deskewed_again;
    if (std::isfinite(rep.start_heading)) // the pose search's start won (degrees)
      s["pose_search_heading_deg"] = rep.start_heading * 180.0 / M_PI;
    s["icp_source_points"] = rep.source_points;
    s["icp_map_scans"] = rep.map_scans;
    s["seconds"] = rep.seconds;
    s["lum_iterations"] = rep.lum_iterations;
    if (rep.sequence_chi2 >= 0.0) // the front end's step against the final poses
      s["sequence_chi2"] = rep.sequence_chi2;
    nlohmann::json tried = nlohmann::json::array();
    for (const auto& c : rep.loops)
      tried.push_back({{"target", c.link.target},
                       {"overlap", c.overlap},
                       {"error", c.error},
                       {"accepted", c.accepted}});
    s["loops_tried"] = tried;
    if (!in.files[i].empty())
      s["file"] = in.files[i];
    scans.push_back(s);
  }
  return scans;
}

/** The front end's matches: how many, failed, placed by the pose search, deskewed again. */
nlohmann::json
icpJson(const Result& r, std::size_t scans)
{
  const auto [searched, found] = poseSearches(r.reports);
  return {
      {"matches", scans - 1},
      {"not_converged", r.icp_failures},
      {"pose_searched", searched},
      {"pose_search_won", found},
      {"deskewed_again",
       std::count_if(
           r.reports.begin(),
           r.reports.end(),
           [](const pcl_parallel::slam::ScanReport& rep) { return rep.deskewed_again; })},
      {"odometry_disagreement",
       r.odometry_disagreement ? nlohmann::json(*r.odometry_disagreement) : nlohmann::json()}};
}

/** The errors against the simulation's truth, per row (truthErrors). */
nlohmann::json
truthJson(const Input& in, const Result& r)
{
  nlohmann::json truth;
  for (const auto& row : truthErrors(in, r)) {
    const auto& e = row.errors;
    truth[row.key] = {{"ate_m", e.ate.translation.rmse},
                      {"ate_deg", e.ate.rotation_deg.rmse},
                      {"kitti_rpe_percent", e.kitti.translation_percent},
                      {"kitti_rpe_deg_per_m", e.kitti.rotation_deg_per_m},
                      {"frame_rpe_m", e.rpe.translation.rmse}};
  }
  return truth;
}

} // namespace

std::vector<std::string>
writeOutputs(const Options& o,
             const Input& in,
             const Result& r,
             ProgressReporter& progress,
             const std::string& command_line)
{
  std::vector<std::string> written;
  const std::size_t n = in.size();
  std::vector<std::pair<std::uint32_t, std::uint32_t>> loops;
  for (const auto& [i, j] : r.links)
    if ((i > j ? i - j : j - i) > 1)
      loops.emplace_back(i, j);

  writePoseFiles(o, in, r, progress, written);
  const double map_voxel = mapVoxel(o, in.scale);
  const Cloud::Ptr map = writeMap(o, in, r, map_voxel, progress, written);
  const std::string style =
      o.picture ? writePicture(o, in, r, *map, map_voxel, loops, progress, written) : "";
  progress.finish();

  // report.json: what was run, with what, and what each stage did and took.
  nlohmann::json j;
  j["program"] = "pcl_pslam";
  j["command_line"] = command_line;
  j["versions"] = versionsJson();
  j["threads"] = pcl_parallel::resolveNumberOfThreads(o.threads);
  j["input"] = inputJson(o, in, r);
  j["parameters"] = parametersJson(r, map_voxel);
  j["pipeline_seconds"] = {{"read", in.read_seconds},
                           {"preprocess", r.times.preprocess},
                           {"front_end", r.times.front_end},
                           {"loop_detection", r.times.loop_detection},
                           {"loop_closing", r.times.loop_closing}};
  j["bytes_kept_per_scan"] = r.bytes_per_scan;
  if (r.spread.segments > 0)
    j["segments"] = {{"segments", r.spread.segments},
                     {"segment_size", r.spread.segment_size},
                     {"overlap", r.mapping.segment_overlap},
                     {"ranks", r.spread.ranks},
                     {"rank0_wait_seconds", r.spread.wait_seconds},
                     {"bytes_shared", r.spread.bytes_shared},
                     {"scans_sent", r.spread.scans_sent},
                     {"max_kept_scans", r.spread.max_kept_scans}};
  j["relaxations"] = r.relaxations;
  nlohmann::json stages = nlohmann::json::array();
  for (const auto& s : progress.stages())
    stages.push_back({{"name", s.name}, {"seconds", s.seconds}, {"steps", s.steps}});
  j["stages"] = stages;
  j["total_seconds"] = progress.elapsed();
  j["scans"] = scansJson(in, r);
  j["icp"] = icpJson(r, n);
  nlohmann::json loop_list = nlohmann::json::array();
  for (const auto& [a, b] : loops)
    loop_list.push_back({a, b});
  j["loops"] = loop_list;
  j["links"] = r.links.size();
  j["lum"] = {{"iterations", r.lum_iterations},
              {"iteration_cap", r.parameters.loops.lum_iterations}};
  j["map"] = {{"points", map->size()}, {"voxel_m", map_voxel}};
  if (!style.empty())
    j["picture_style"] = style;
  if (!in.truth.empty())
    j["errors_against_truth"] = truthJson(in, r);
  j["outputs"] = written;
  pcl_parallel::io::writeStreamAtomically(join(o.out, "report.json"),
                                          [&](std::ostream& out) { out << j.dump(2) << '\n'; });
  written.push_back("report.json");
  return written;
}

void
printSummary(const Options& o,
             const Input& in,
             const Result& r,
             const std::vector<std::string>& written,
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
  // Matches the pose search found came from nothing but the scans: right on a distinct
  // site, possibly a room or corridor away where the site repeats (docs/design.md,
  // "Pose search").
  if (const auto [searched, found] = poseSearches(r.reports); found > 0)
    std::printf("pose search: %zu of %zu matches searched (no initial poses), %zu placed by "
                "it; where the site repeats (rooms, corridors) check them in map.png, or "
                "give --poses\n",
                searched,
                in.size() - 1,
                found);
  // Odometry the scans contradict step after step is in another frame, or broken
  // (docs/design.md, "Odometry in another frame").
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
  // Where the relaxation and the front end disagree most: the first places to look at in
  // a map. Steps beyond chi2's 99 % quantile for 6 degrees of freedom, or the kernel's
  // scale where one is set.
  const double notable = r.parameters.loops.sequence_cauchy_scale > 0.0
                             ? r.parameters.loops.sequence_cauchy_scale
                             : pcl_parallel::slam::kChi2Quantile99SixDof;
  std::vector<std::pair<double, std::size_t>> chi2;
  for (std::size_t i = 0; i < r.reports.size(); ++i)
    if (r.reports[i].sequence_chi2 > notable)
      chi2.emplace_back(r.reports[i].sequence_chi2, i);
  std::sort(chi2.rbegin(), chi2.rend());
  if (!chi2.empty()) {
    std::string worst;
    for (std::size_t k = 0; k < chi2.size() && k < 3; ++k)
      worst += (k ? ", " : "") + std::to_string(in.numbers[chi2[k].second]) + " (chi2 " +
               std::to_string(static_cast<long long>(std::lround(chi2[k].first))) + ")";
    std::printf("loop closing disagreed most with the front end's steps to scans %s; "
                "report.json: sequence_chi2\n",
                worst.c_str());
  }
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
    pcl_pslam::printTruthErrors(std::cout, in, r);
  std::string names;
  for (const auto& w : written)
    names += (names.empty() ? "" : ", ") + w;
  std::printf("wrote %s/{%s} in %.1f s\n", o.out.c_str(), names.c_str(), seconds);
}

} // namespace pcl_pslam
