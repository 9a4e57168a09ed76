/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "outputs.h"

#include <pcl_parallel/evaluation/report.h>
#include <pcl_parallel/io/atomic_write.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/slam/findings.h>
#include <pcl_parallel/slam/run_outputs.h>
#include <pcl_parallel/version.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#ifndef PCL_PSLAM_VERSION
#define PCL_PSLAM_VERSION "unknown"
#endif

namespace fs = std::filesystem;
namespace ev = pcl_parallel::evaluation;
using nlohmann::json;

namespace pcl_pslam {

namespace {

/** The odometry's (where the run had one), the front end's and the final poses' errors
 *  against the simulation's truth: the console, map.png and report.json give the same. */
std::vector<ev::NamedEvaluation>
truthErrors(const Input& in, const Result& r)
{
  return ev::evaluateRun(in.odometry ? in.initial : Poses{}, r.icp, r.final, in.truth);
}

/** The odometry's, the front end's and the final poses' errors against the truth. */
void
printTruthErrors(std::ostream& out, const Input& in, const Result& r)
{
  const auto lengths = ev::kittiLengthsFor(in.truth);
  out << "errors against the simulation's truth (ATE after SE(3) alignment; RPE as the KITTI "
         "devkit, over "
      << lengths.front() << ".." << lengths.back() << " m):\n";
  ev::printErrorRows(out, truthErrors(in, r));
}

/** What the run was built with (a result traced to its build). */
json
versionsJson()
{
  json versions = {{"pcl_pslam", PCL_PSLAM_VERSION}};
  for (const auto& [name, version] : pcl_parallel::buildVersions())
    versions[name] = version;
  return versions;
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
                                        {"frame_rpe_m", e.rpe.translation.rmse},
                                        {"frame_rpe_deg", e.rpe.rotation_deg.rmse},
                                        {"worst_step_m", e.rpe.translation.max},
                                        {"worst_step_deg", e.rpe.rotation_deg.max}};
    }
  return j;
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

pcl_parallel::slam::RunOutputOptions
runOutputOptions(const Options& o, const Input& in, const Result& r)
{
  pcl_parallel::slam::RunOutputOptions options;
  options.map_voxel = mapVoxel(o, in.scale);
  options.ply = o.ply;
  options.picture = o.picture;
  options.style = o.style;
  options.num_threads = o.threads;
  if (!in.truth.empty()) {
    std::string errors = "ATE against the truth (SE(3)-aligned):";
    char line[128];
    for (const auto& row : truthErrors(in, r)) {
      std::snprintf(
          line, sizeof line, " %s %.3f m,", row.name.c_str(), row.errors.ate.translation.rmse);
      errors += line;
    }
    errors.pop_back();
    options.caption.push_back(errors);
  }
  options.caption.push_back(o.command == "demo" ? "pcl_pslam demo" : "pcl_pslam run " + o.dir);
  return options;
}

std::vector<std::string>
writeOutputs(const Options& o,
             const std::string& dir,
             const Input& in,
             const Result& r,
             ProgressReporter& progress,
             const std::string& command_line)
{
  const auto outputs = pcl_parallel::slam::writeRunOutputs(
      dir,
      in,
      r,
      runOutputOptions(o, in, r),
      [&](const char* stage, std::size_t k, std::size_t n) { progress.update(stage, k, n); });
  std::vector<std::string> written = outputs.written;
  progress.update("report", 0, 1);
  progress.finish();
  json j = reportJson(o, in, r, progress);
  j["command_line"] = command_line;
  j["map"] = {{"points", outputs.map_points}, {"voxel_m", mapVoxel(o, in.scale)}};
  if (!outputs.picture_style.empty())
    j["picture_style"] = outputs.picture_style;
  j["outputs"] = written;
  pcl_parallel::io::writeStreamAtomically(
      (fs::path(dir) / "report.json").string(), [&](std::ostream& out) {
        out << j.dump(2, ' ', false, json::error_handler_t::replace) << '\n';
      });
  written.push_back("report.json");
  return written;
}

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
  if (r.revisit_links > 0)
    std::printf("pLUM: %zu of the loop links where revisits disagreed after the run; "
                "report.json: lum revisit_links\n",
                r.revisit_links);
  for (const auto& f : pcl_parallel::slam::findings(r, in.numbers)) // about the input: stderr
    std::fprintf(f.input_suspect ? stderr : stdout,
                 f.input_suspect ? "pcl_pslam: warning: %s\n" : "%s\n",
                 f.text.c_str());
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
