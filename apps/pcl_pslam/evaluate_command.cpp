/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "evaluate_command.h"

#include <pcl_parallel/io/pose_files.h>

#include <boost/program_options.hpp>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

namespace pcl_pslam {

namespace po = boost::program_options;
namespace ev = pcl_parallel::evaluation;
namespace pio = pcl_parallel::io;
using nlohmann::json;

namespace {

constexpr const char* kUsage =
    "usage: pcl_pslam evaluate ESTIMATE GROUND_TRUTH [options]\n"
    "\n"
    "Absolute trajectory error (ATE, as evo_ape) and relative pose errors (per frame as\n"
    "evo_rpe, over path lengths as the KITTI odometry devkit) of ESTIMATE against\n"
    "GROUND_TRUTH. Each is a KITTI poses file (12 numbers a line), a TUM file (timestamp\n"
    "tx ty tz qx qy qz qw) or a directory of 3DTK scanNNN.frames. Poses are paired by\n"
    "timestamp when both files have them, else by index.\n";

/** A usage error: exit code 2. */
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::vector<double>
parseLengths(const std::string& text)
{
  if (text == "auto")
    return {};
  if (text == "kitti")
    return ev::kittiDefaultLengths();
  std::vector<double> lengths;
  std::stringstream ss(text);
  ss.imbue(std::locale::classic());
  std::string item;
  while (std::getline(ss, item, ',')) {
    std::istringstream is(item);
    is.imbue(std::locale::classic());
    double v;
    if (!(is >> v) || !(is >> std::ws).eof() || !(v > 0.0) || !std::isfinite(v))
      throw UsageError("--lengths: \"" + item +
                       "\" is not a positive number (give "
                       "auto, kitti, or lengths in metres like 10,20,40)");
    lengths.push_back(v);
  }
  if (lengths.empty())
    throw UsageError("--lengths: no length given");
  return lengths;
}

json
statsJson(const ev::Statistics& s)
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
ateJson(const ev::AbsoluteError& a)
{
  return {{"alignment", ev::toString(a.alignment)},
          {"scale", a.similarity.scale},
          {"translation_m", statsJson(a.translation)},
          {"rotation_deg", statsJson(a.rotation_deg)}};
}

void
statsRow(std::ostream& out, const std::string& name, const ev::Statistics& s)
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

std::string
describe(const std::string& path, const pio::Trajectory& t)
{
  return path + " (" + pio::toString(t.format) + ", " + std::to_string(t.poses.size()) +
         " poses" + (t.timestamps.empty() ? "" : ", timestamps") + ")";
}

/** The estimate's and the truth's poses paired: by timestamp where both files have them
 *  (evo's association within max_diff), else by index; and how, in words. */
struct Paired {
  ev::Poses estimate, truth;
  std::string association;
};

Paired
pairTrajectories(const pio::Trajectory& est,
                 const std::string& estimate_path,
                 const pio::Trajectory& truth,
                 const std::string& truth_path,
                 double max_diff,
                 bool truncate)
{
  Paired p;
  if (!est.timestamps.empty() && !truth.timestamps.empty()) {
    const auto pairs = ev::associateByTimestamp(est.timestamps, truth.timestamps, max_diff);
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

} // namespace

json
evaluationToJson(const ev::TrajectoryEvaluation& e)
{
  json kitti = {{"lengths_m", e.kitti.lengths},
                {"step_frames", e.kitti.step},
                {"segments", e.kitti.segments.size()},
                {"translation_percent", nullptr},
                {"rotation_deg_per_m", nullptr},
                {"per_length", json::array()}};
  if (e.kitti.valid()) {
    kitti["translation_percent"] = e.kitti.translation_percent;
    kitti["rotation_deg_per_m"] = e.kitti.rotation_deg_per_m;
  }
  for (const auto& l : e.kitti.per_length) {
    json j = {{"length_m", l.length},
              {"segments", l.segments},
              {"translation_percent", nullptr},
              {"rotation_deg_per_m", nullptr}};
    if (l.segments > 0) {
      j["translation_percent"] = l.translation_percent;
      j["rotation_deg_per_m"] = l.rotation_deg_per_m;
    }
    kitti["per_length"].push_back(j);
  }
  return {{"poses", e.poses},
          {"path_length_m", e.reference_path_length},
          {"ate", ateJson(e.ate)},
          {"ate_unaligned", ateJson(e.ate_unaligned)},
          {"rpe_frame",
           {{"delta_frames", e.rpe.delta},
            {"translation_m", statsJson(e.rpe.translation)},
            {"rotation_deg", statsJson(e.rpe.rotation_deg)},
            {"point_distance_m", statsJson(e.rpe.point_distance)}}},
          {"rpe_kitti", kitti}};
}

void
printEvaluation(std::ostream& out, const ev::TrajectoryEvaluation& e)
{
  const std::ios::fmtflags flags = out.flags();
  const std::streamsize precision = out.precision();
  out << std::fixed << std::setprecision(4);
  statsHeader(out, "ATE (" + ev::toString(e.ate.alignment) + " alignment)");
  statsRow(out, "translation [m]", e.ate.translation);
  statsRow(out, "rotation [deg]", e.ate.rotation_deg);
  if (e.ate.alignment == ev::Alignment::Sim3)
    out << "  scale " << e.ate.similarity.scale << '\n';
  if (e.ate.alignment != ev::Alignment::None) {
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

int
evaluateCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err)
{
  std::string estimate_path, truth_path, align = "se3", lengths_text = "auto";
  std::size_t step = 10, delta = 1;
  double max_diff = 0.01, frames_unit = pio::kFramesUnit;
  bool as_json = false, truncate = false;
  po::options_description options("options");
  options.add_options()("help,h", "this text")(
      "json", po::bool_switch(&as_json), "print JSON instead of a table")(
      "align",
      po::value(&align)->default_value(align),
      "alignment before the ATE: none, se3 (rigid, evo_ape --align) or sim3 (with scale, "
      "--correct_scale; also rescales the RPE)")(
      "lengths",
      po::value(&lengths_text)->default_value(lengths_text),
      "KITTI RPE segment lengths in metres, comma-separated; kitti = the devkit's "
      "100,...,800; auto = the devkit's when the ground truth's path is longer than 800 m, "
      "else 10%,...,80% of its length")("step",
                                        po::value(&step)->default_value(step),
                                        "KITTI RPE: frames between segment starts")(
      "delta", po::value(&delta)->default_value(delta), "per-frame RPE: frames between pairs")(
      "max-diff",
      po::value(&max_diff)->default_value(max_diff),
      "largest timestamp difference (s) of an associated pair (evo's --t_max_diff)")(
      "frames-unit",
      po::value(&frames_unit)->default_value(frames_unit),
      "metres per unit of .frames translations (3DTK: centimetres, 0.01)")(
      "truncate",
      po::bool_switch(&truncate),
      "pairing by index: compare the first min(n, m) poses when the counts differ (else an "
      "error)");
  po::options_description hidden;
  hidden.add_options()("estimate", po::value(&estimate_path))("ground-truth",
                                                              po::value(&truth_path));
  po::options_description all;
  all.add(options).add(hidden);
  po::positional_options_description positional;
  positional.add("estimate", 1).add("ground-truth", 1);

  ev::EvaluationOptions eo;
  try {
    po::variables_map vm;
    po::store(po::command_line_parser(args).options(all).positional(positional).run(), vm);
    if (vm.count("help")) {
      out << kUsage << '\n' << options;
      return 0;
    }
    po::notify(vm);
    if (estimate_path.empty() || truth_path.empty())
      throw UsageError("needs ESTIMATE and GROUND_TRUTH");
    try {
      eo.alignment = ev::alignmentFromString(align);
    }
    catch (const std::invalid_argument& e) {
      throw UsageError(std::string("--align: ") + e.what());
    }
    eo.kitti_lengths = parseLengths(lengths_text);
    if (step == 0 || delta == 0)
      throw UsageError("--step and --delta must be at least 1");
    if (!(max_diff >= 0.0) || !(frames_unit > 0.0))
      throw UsageError("--max-diff must be >= 0 and --frames-unit > 0");
    eo.kitti_step = step;
    eo.rpe_delta = delta;
  }
  catch (const std::exception& e) { // po::error or UsageError
    err << "pcl_pslam evaluate: " << e.what() << " (pcl_pslam evaluate --help)\n";
    return 2;
  }

  try {
    const pio::Trajectory est = pio::loadTrajectory(estimate_path, frames_unit);
    const pio::Trajectory truth = pio::loadTrajectory(truth_path, frames_unit);
    ev::requireRigidMotions(est.poses, estimate_path); // named by file, before pairing
    ev::requireRigidMotions(truth.poses, truth_path);
    const Paired paired =
        pairTrajectories(est, estimate_path, truth, truth_path, max_diff, truncate);
    const ev::Poses& e = paired.estimate;
    const ev::Poses& t = paired.truth;
    const std::string& association = paired.association;
    const ev::TrajectoryEvaluation result = ev::evaluateTrajectory(e, t, eo);
    if (as_json) {
      auto file = [](const std::string& path, const pio::Trajectory& tr) {
        return json{{"path", path},
                    {"format", pio::toString(tr.format)},
                    {"poses", tr.poses.size()},
                    {"timestamps", !tr.timestamps.empty()}};
      };
      json j = evaluationToJson(result);
      j["estimate"] = file(estimate_path, est);
      j["ground_truth"] = file(truth_path, truth);
      j["association"] = association;
      out << j.dump(2) << '\n';
    }
    else {
      out << "estimate      " << describe(estimate_path, est) << '\n'
          << "ground truth  " << describe(truth_path, truth) << '\n'
          << "paired        " << association << '\n'
          << "path length   " << std::fixed << std::setprecision(3)
          << result.reference_path_length << " m (ground truth)\n"
          << std::defaultfloat << '\n';
      printEvaluation(out, result);
    }
    return 0;
  }
  catch (const std::exception& ex) {
    err << "pcl_pslam evaluate: " << ex.what() << '\n';
    return 1;
  }
}

} // namespace pcl_pslam
