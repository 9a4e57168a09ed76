/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/io/scan_directory.h>
#include <pcl_parallel/slam/mapping.h>

#include <cmath>
#include <nlohmann/json.hpp>

namespace pcl_parallel {
namespace slam {

using nlohmann::json;

namespace {

/** The parameters as the pipeline resolved them (lengths in m). */
json
parametersJson(const Parameters& p)
{
  const MatcherParameters& m = p.matcher;
  const LoopClosureParameters& l = p.loops;
  const Eigen::Vector3d& up = p.guess.up;
  return {{"voxel_size_m", p.reduction.voxel_size},
          {"source_voxel_size_m", p.reduction.source_voxel_size},
          {"map_voxel_size_m", m.map_voxel_size},
          {"map_distance_m", m.map_distance},
          {"icp_distance_m", m.max_correspondence_distance},
          {"icp_final_distance_m", m.final_correspondence_distance},
          {"icp_adaptive_threshold", m.adaptive_threshold},
          {"icp_point_to_plane", m.point_to_plane},
          {"icp_map_normals", m.normals_from_map},
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
          {"lum_revisit_rounds", l.revisit_rounds},
          {"elch", l.distribute_error},
          {"scan_to_scan", m.target == MatchTarget::kPreviousScan},
          {"deskew", p.deskew.enabled},
          {"sweep_period_s", p.deskew.sweep_period},
          {"sweep_clockwise", p.deskew.sweep_clockwise},
          {"pose_search", p.guess.pose_search},
          {"up", std::vector<double>{up.x(), up.y(), up.z()}},
          {"planar", p.planar},
          {"close_loops", l.enabled}};
}

/** Scan i: what it was, what the front end did with it, the loop pairs tried. */
json
scanJson(const ScanReport& rep, const io::ScanDirectory& scans, std::size_t i)
{
  json tried = json::array();
  for (const auto& c : rep.loops)
    tried.push_back({{"target", c.link.target},
                     {"overlap", c.overlap},
                     {"error", c.error},
                     {"accepted", c.accepted},
                     {"searched", c.searched}});
  json s = {{"index", i},
            {"number", scans.numbers.at(i)},
            {"stamp", scans.stamps.at(i)},
            {"points", rep.points},
            {"points_reduced", rep.reduced_points},
            {"icp_converged", rep.converged},
            {"icp_fitness", rep.fitness},
            {"icp_gate", rep.gate},
            {"icp_correction", rep.correction},
            {"icp_start_offset", rep.start_offset},
            {"icp_start_turn", rep.start_turn},
            {"pose_searched", rep.pose_searched},
            {"deskewed_again", rep.deskewed_again},
            {"icp_source_points", rep.source_points},
            {"icp_map_scans", rep.map_scans},
            {"seconds", rep.seconds},
            {"lum_iterations", rep.lum_iterations},
            {"loops_tried", tried}};
  if (std::isfinite(rep.start_heading)) // the pose search's start won (degrees)
    s["pose_search_heading_deg"] = rep.start_heading * 180.0 / M_PI;
  if (rep.sequence_chi2 >= 0.0) // the front end's step against the final poses
    s["sequence_chi2"] = rep.sequence_chi2;
  if (!scans.files.at(i).empty())
    s["file"] = scans.files[i];
  return s;
}

/** The segmented backends' figures. */
json
segmentsJson(const MappingResult& r)
{
  const MappingReport& s = r.spread;
  return {{"segments", s.segments},
          {"segment_size", s.segment_size},
          {"overlap", r.mapping.segment_overlap},
          {"ranks", s.ranks},
          {"rank0_wait_seconds", s.wait_seconds},
          {"bytes_shared", s.bytes_shared},
          {"scans_sent", s.scans_sent},
          {"max_kept_scans", s.max_kept_scans}};
}

} // namespace

std::vector<std::pair<std::uint32_t, std::uint32_t>>
loopLinks(const MappingResult& r)
{
  std::vector<std::pair<std::uint32_t, std::uint32_t>> loops;
  for (const auto& [a, b] : r.links)
    if ((a > b ? a - b : b - a) > 1)
      loops.emplace_back(a, b);
  return loops;
}

std::string
toJson(const MappingResult& r,
       const io::ScanDirectory& scans,
       const DirectoryReading& reading,
       int indent)
{
  json j = {{"parameters", parametersJson(r.parameters)},
            {"pipeline_seconds",
             {{"read", reading.seconds},
              {"preprocess", r.times.preprocess},
              {"front_end", r.times.front_end},
              {"loop_detection", r.times.loop_detection},
              {"loop_closing", r.times.loop_closing}}},
            {"bytes_kept_per_scan", r.bytes_per_scan},
            {"relaxations", r.relaxations},
            {"scans", json::array()},
            {"icp",
             {{"matches", r.reports.empty() ? 0 : r.reports.size() - 1},
              {"not_converged", r.icp_failures},
              {"pose_searched", r.pose_searched},
              {"pose_search_won", r.pose_search_won},
              {"deskewed_again", r.deskewed_again},
              {"odometry_disagreement",
               r.odometry_disagreement ? json(*r.odometry_disagreement) : json()}}},
            {"loops", json::array()},
            {"links", r.links.size()},
            {"consistency",
             {{"revisits", r.consistency.pairs},
              {"mean_conflicts", r.consistency.mean_conflicts},
              {"conflicting", r.consistency.conflicting},
              {"front_end",
               {{"revisits", r.consistency_icp.pairs},
                {"mean_conflicts", r.consistency_icp.mean_conflicts},
                {"conflicting", r.consistency_icp.conflicting}}}}},
            {"lum",
             {{"iterations", r.lum_iterations},
              {"iteration_cap", r.parameters.loops.lum_iterations},
              {"revisit_links", r.revisit_links}}}};
  for (std::size_t i = 0; i < r.reports.size(); ++i)
    j["scans"].push_back(scanJson(r.reports[i], scans, i));
  for (const auto& [a, b] : loopLinks(r))
    j["loops"].push_back({a, b});
  if (r.spread.segments > 0)
    j["segments"] = segmentsJson(r);
  // A name that is not UTF-8 (JSON's encoding) gets U+FFFD, never a failure after the work.
  return j.dump(indent, ' ', false, json::error_handler_t::replace);
}

} // namespace slam
} // namespace pcl_parallel
