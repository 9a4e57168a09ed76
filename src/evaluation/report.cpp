/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/evaluation/report.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <locale>
#include <nlohmann/json.hpp> // here only: the installed headers do not need it
#include <sstream>
#include <stdexcept>

namespace pcl_parallel {
namespace evaluation {

namespace {

void
statsRow(std::ostream& out, const std::string& name, const Statistics& s)
{
  out << "  " << std::left << std::setw(20) << name << std::right;
  for (double v : {s.rmse, s.mean, s.median, s.std, s.min, s.max})
    out << std::setw(10) << v;
  out << '\n';
}

void
statsHeader(std::ostream& out, const std::string& title)
{
  out << std::left << std::setw(22) << title << std::right;
  for (const char* c : {"rmse", "mean", "median", "std", "min", "max"})
    out << std::setw(10) << c;
  out << '\n';
}

using nlohmann::json;

json
statsJson(const Statistics& s)
{
  return {{"count", s.count},
          {"rmse", s.rmse},
          {"mean", s.mean},
          {"median", s.median},
          {"std", s.std},
          {"min", s.min},
          {"max", s.max}};
}

json
ateJson(const AbsoluteError& a)
{
  return {{"alignment", toString(a.alignment)},
          {"scale", a.similarity.scale},
          {"translation_m", statsJson(a.translation)},
          {"rotation_deg", statsJson(a.rotation_deg)}};
}

/** The KITTI RPE; its rates are null where no segment fits. */
json
kittiJson(const KittiRelativeError& k)
{
  const auto rates = [](json j, bool valid, double translation, double rotation) {
    j["translation_percent"] = valid ? json(translation) : json(nullptr);
    j["rotation_deg_per_m"] = valid ? json(rotation) : json(nullptr);
    return j;
  };
  json per_length = json::array();
  for (const auto& l : k.per_length)
    per_length.push_back(rates({{"length_m", l.length}, {"segments", l.segments}},
                               l.segments > 0,
                               l.translation_percent,
                               l.rotation_deg_per_m));
  return rates({{"lengths_m", k.lengths},
                {"step_frames", k.step},
                {"segments", k.segments.size()},
                {"per_length", per_length}},
               k.valid(),
               k.translation_percent,
               k.rotation_deg_per_m);
}

} // namespace

PairedTrajectories
pairTrajectories(const io::Trajectory& est,
                 const std::string& estimate_path,
                 const io::Trajectory& truth,
                 const std::string& truth_path,
                 double max_diff,
                 bool truncate)
{
  PairedTrajectories p;
  if (!est.timestamps.empty() && !truth.timestamps.empty()) {
    const auto pairs = associateByTimestamp(est.timestamps, truth.timestamps, max_diff);
    if (pairs.empty())
      throw std::runtime_error("no timestamps of " + estimate_path + " and " + truth_path +
                               " lie within --max-diff " + std::to_string(max_diff) + " s");
    for (const auto& [i, j] : pairs) {
      p.estimate.push_back(est.poses[i]);
      p.truth.push_back(truth.poses[j]);
    }
    p.association = "by timestamp (max diff " + std::to_string(max_diff) +
                    " s): " + std::to_string(pairs.size()) + " pairs of " +
                    std::to_string(std::min(est.poses.size(), truth.poses.size())) +
                    " possible";
    return p;
  }
  const std::size_t n = std::min(est.poses.size(), truth.poses.size());
  if (est.poses.size() != truth.poses.size() && !truncate)
    throw std::runtime_error("pairing by index (not both files have timestamps), but " +
                             estimate_path + " has " + std::to_string(est.poses.size()) +
                             " poses and " + truth_path + " " +
                             std::to_string(truth.poses.size()) +
                             " (--truncate compares the first " + std::to_string(n) + ")");
  p.estimate.assign(est.poses.begin(), est.poses.begin() + static_cast<std::ptrdiff_t>(n));
  p.truth.assign(truth.poses.begin(), truth.poses.begin() + static_cast<std::ptrdiff_t>(n));
  p.association =
      "by index" +
      std::string(est.poses.size() != truth.poses.size()
                      ? " (truncated to the first " + std::to_string(n) + ")"
                      : "") +
      (est.timestamps.empty() && truth.timestamps.empty() ? ": neither file has timestamps"
                                                          : ": only one file has timestamps");
  return p;
}

std::string
describe(const std::string& path, const io::Trajectory& t)
{
  return path + " (" + io::toString(t.format) + ", " + std::to_string(t.poses.size()) +
         " poses" + (t.timestamps.empty() ? "" : ", timestamps") + ")";
}

void
printEvaluation(std::ostream& out, const TrajectoryEvaluation& e)
{
  const std::ios::fmtflags flags = out.flags();
  const std::streamsize precision = out.precision();
  out << std::fixed << std::setprecision(4);
  statsHeader(out, "ATE (" + toString(e.ate.alignment) + " alignment)");
  statsRow(out, "translation [m]", e.ate.translation);
  statsRow(out, "rotation [deg]", e.ate.rotation_deg);
  if (e.ate.alignment == Alignment::Sim3)
    out << "  scale " << e.ate.similarity.scale << '\n';
  if (e.ate.alignment != Alignment::None) {
    statsHeader(out, "ATE (no alignment)");
    statsRow(out, "translation [m]", e.ate_unaligned.translation);
    statsRow(out, "rotation [deg]", e.ate_unaligned.rotation_deg);
  }
  statsHeader(out, "RPE (delta " + std::to_string(e.rpe.delta) + " frame)");
  statsRow(out, "translation [m]", e.rpe.translation);
  statsRow(out, "rotation [deg]", e.rpe.rotation_deg);
  statsRow(out, "point distance [m]", e.rpe.point_distance);
  out << "KITTI RPE (step " << e.kitti.step << " frames)";
  if (!e.kitti.valid()) {
    out << ": no segment fits the ground truth's path\n";
  }
  else {
    out << ": translation " << e.kitti.translation_percent << " %, rotation "
        << e.kitti.rotation_deg_per_m << " deg/m over " << e.kitti.segments.size()
        << " segments\n";
    for (const auto& l : e.kitti.per_length) {
      out << "  " << std::setw(10) << l.length << " m  " << std::setw(4) << l.segments
          << " segments";
      if (l.segments > 0)
        out << std::setw(10) << l.translation_percent << " %" << std::setw(10)
            << l.rotation_deg_per_m << " deg/m";
      out << '\n';
    }
  }
  out.flags(flags);
  out.precision(precision);
}

std::vector<double>
kittiLengthsFromString(const std::string& text)
{
  if (text == "auto")
    return {};
  if (text == "kitti")
    return kittiDefaultLengths();
  std::vector<double> lengths;
  std::stringstream ss(text);
  ss.imbue(std::locale::classic());
  std::string item;
  while (std::getline(ss, item, ',')) {
    std::istringstream is(item);
    is.imbue(std::locale::classic());
    double v;
    if (!(is >> v) || !(is >> std::ws).eof() || !(v > 0.0) || !std::isfinite(v))
      throw std::invalid_argument("\"" + item +
                                  "\" is not a positive number (give auto, kitti, or "
                                  "lengths in metres like 10,20,40)");
    lengths.push_back(v);
  }
  if (lengths.empty())
    throw std::invalid_argument("no length given");
  return lengths;
}

FileEvaluation
evaluateFiles(const std::string& estimate_path,
              const std::string& truth_path,
              const FileEvaluationOptions& options)
{
  FileEvaluation e;
  e.estimate_path = estimate_path;
  e.truth_path = truth_path;
  e.estimate = io::loadTrajectory(estimate_path, options.frames_unit);
  e.truth = io::loadTrajectory(truth_path, options.frames_unit);
  requireRigidMotions(e.estimate.poses, estimate_path); // named by file, before pairing
  requireRigidMotions(e.truth.poses, truth_path);
  const PairedTrajectories paired = pairTrajectories(
      e.estimate, estimate_path, e.truth, truth_path, options.max_diff, options.truncate);
  e.association = paired.association;
  e.errors = evaluateTrajectory(paired.estimate, paired.truth, options.evaluation);
  return e;
}

void
printFileEvaluation(std::ostream& out, const FileEvaluation& e)
{
  const std::ios::fmtflags flags = out.flags();
  const std::streamsize precision = out.precision();
  out << "estimate      " << describe(e.estimate_path, e.estimate) << '\n'
      << "ground truth  " << describe(e.truth_path, e.truth) << '\n'
      << "paired        " << e.association << '\n'
      << "path length   " << std::fixed << std::setprecision(3)
      << e.errors.reference_path_length << " m (ground truth)\n"
      << std::defaultfloat << '\n';
  printEvaluation(out, e.errors);
  out.flags(flags);
  out.precision(precision);
}

std::string
toJson(const FileEvaluation& f, int indent)
{
  const auto file = [](const std::string& path, const io::Trajectory& tr) {
    return json{{"path", path},
                {"format", io::toString(tr.format)},
                {"poses", tr.poses.size()},
                {"timestamps", !tr.timestamps.empty()}};
  };
  const TrajectoryEvaluation& e = f.errors;
  const json j = {{"poses", e.poses},
                  {"path_length_m", e.reference_path_length},
                  {"ate", ateJson(e.ate)},
                  {"ate_unaligned", ateJson(e.ate_unaligned)},
                  {"rpe_frame",
                   {{"delta_frames", e.rpe.delta},
                    {"translation_m", statsJson(e.rpe.translation)},
                    {"rotation_deg", statsJson(e.rpe.rotation_deg)},
                    {"point_distance_m", statsJson(e.rpe.point_distance)}}},
                  {"rpe_kitti", kittiJson(e.kitti)},
                  {"estimate", file(f.estimate_path, f.estimate)},
                  {"ground_truth", file(f.truth_path, f.truth)},
                  {"association", f.association}};
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace); // as report.json
}

std::vector<NamedEvaluation>
evaluateRun(const Poses& odometry,
            const Poses& front_end,
            const Poses& final_poses,
            const Poses& truth)
{
  std::vector<NamedEvaluation> rows;
  if (!odometry.empty())
    rows.push_back({"odometry", evaluateTrajectory(odometry, truth)});
  rows.push_back({"front end", evaluateTrajectory(front_end, truth)});
  rows.push_back({"final", evaluateTrajectory(final_poses, truth)});
  return rows;
}

void
printErrorRows(std::ostream& out, const std::vector<NamedEvaluation>& rows)
{
  char line[200]; // printf's fixed widths: the columns line up whatever the stream's state
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
  for (const auto& [name, e] : rows) {
    std::snprintf(line,
                  sizeof line,
                  "  %-10s %10.4f %10.3f %9.3f %10.5f %12.4f\n",
                  name.c_str(),
                  e.ate.translation.rmse,
                  e.ate.rotation_deg.rmse,
                  e.kitti.translation_percent,
                  e.kitti.rotation_deg_per_m,
                  e.rpe.translation.rmse);
    out << line;
  }
}

} // namespace evaluation
} // namespace pcl_parallel
