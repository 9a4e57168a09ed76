/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "evaluate_command.h"

#include <pcl_parallel/evaluation/report.h>
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

namespace {

/** What `evaluate` is told. */
struct EvaluateArguments {
  std::string estimate_path, truth_path, align = "se3", lengths_text = "auto";
  std::size_t step = 10, delta = 1;
  double max_diff = 0.01, frames_unit = pio::kFramesUnit;
  bool as_json = false, truncate = false;
};

/** `evaluate`'s options, bound to `a`. */
po::options_description
evaluateOptions(EvaluateArguments& a)
{
  po::options_description options("options");
  options.add_options()("help,h", "this text")(
      "json", po::bool_switch(&a.as_json), "print JSON instead of a table")(
      "align",
      po::value(&a.align)->default_value(a.align),
      "alignment before the ATE: none, se3 (rigid, evo_ape --align) or sim3 (with scale, "
      "--correct_scale; also rescales the RPE)")(
      "lengths",
      po::value(&a.lengths_text)->default_value(a.lengths_text),
      "KITTI RPE segment lengths in metres, comma-separated; kitti = the devkit's "
      "100,...,800; auto = the devkit's when the ground truth's path is longer than 800 m, "
      "else 10%,...,80% of its length")("step",
                                        po::value(&a.step)->default_value(a.step),
                                        "KITTI RPE: frames between segment starts")(
      "delta",
      po::value(&a.delta)->default_value(a.delta),
      "per-frame RPE: frames between pairs")(
      "max-diff",
      po::value(&a.max_diff)->default_value(a.max_diff),
      "largest timestamp difference (s) of an associated pair (evo's --t_max_diff)")(
      "frames-unit",
      po::value(&a.frames_unit)->default_value(a.frames_unit),
      "metres per unit of .frames translations (3DTK: centimetres, 0.01)")(
      "truncate",
      po::bool_switch(&a.truncate),
      "pairing by index: compare the first min(n, m) poses when the counts differ (else an "
      "error)");
  return options;
}

/** Parses and checks `args` into `a` and `eo`; false where --help was answered. Throws
 *  po::error or UsageError. */
bool
parseEvaluateArguments(const std::vector<std::string>& args,
                       EvaluateArguments& a,
                       ev::EvaluationOptions& eo,
                       std::ostream& out)
{
  const po::options_description options = evaluateOptions(a);
  po::options_description hidden;
  hidden.add_options()("estimate", po::value(&a.estimate_path))("ground-truth",
                                                                po::value(&a.truth_path));
  po::options_description all;
  all.add(options).add(hidden);
  po::positional_options_description positional;
  positional.add("estimate", 1).add("ground-truth", 1);
  po::variables_map vm;
  po::store(po::command_line_parser(args).options(all).positional(positional).run(), vm);
  if (vm.count("help")) {
    out << kUsage << '\n' << options;
    return false;
  }
  po::notify(vm);
  if (a.estimate_path.empty() || a.truth_path.empty())
    throw UsageError("needs ESTIMATE and GROUND_TRUTH");
  try {
    eo.alignment = ev::alignmentFromString(a.align);
  }
  catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--align: ") + e.what());
  }
  eo.kitti_lengths = parseLengths(a.lengths_text);
  if (a.step == 0 || a.delta == 0)
    throw UsageError("--step and --delta must be at least 1");
  if (!(a.max_diff >= 0.0) || !(a.frames_unit > 0.0))
    throw UsageError("--max-diff must be >= 0 and --frames-unit > 0");
  eo.kitti_step = a.step;
  eo.rpe_delta = a.delta;
  return true;
}

/** The evaluation as a table or as JSON. */
void
printResult(std::ostream& out,
            const EvaluateArguments& a,
            const pio::Trajectory& est,
            const pio::Trajectory& truth,
            const std::string& association,
            const ev::TrajectoryEvaluation& result)
{
  if (a.as_json) {
    auto file = [](const std::string& path, const pio::Trajectory& tr) {
      return json{{"path", path},
                  {"format", pio::toString(tr.format)},
                  {"poses", tr.poses.size()},
                  {"timestamps", !tr.timestamps.empty()}};
    };
    json j = evaluationToJson(result);
    j["estimate"] = file(a.estimate_path, est);
    j["ground_truth"] = file(a.truth_path, truth);
    j["association"] = association;
    out << j.dump(2) << '\n';
    return;
  }
  out << "estimate      " << ev::describe(a.estimate_path, est) << '\n'
      << "ground truth  " << ev::describe(a.truth_path, truth) << '\n'
      << "paired        " << association << '\n'
      << "path length   " << std::fixed << std::setprecision(3) << result.reference_path_length
      << " m (ground truth)\n"
      << std::defaultfloat << '\n';
  ev::printEvaluation(out, result);
}

} // namespace

int
evaluateCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err)
{
  EvaluateArguments a;
  ev::EvaluationOptions eo;
  try {
    if (!parseEvaluateArguments(args, a, eo, out))
      return 0;
  }
  catch (const std::exception& e) { // po::error or UsageError
    err << "pcl_pslam evaluate: " << e.what() << " (pcl_pslam evaluate --help)\n";
    return 2;
  }
  try {
    const pio::Trajectory est = pio::loadTrajectory(a.estimate_path, a.frames_unit);
    const pio::Trajectory truth = pio::loadTrajectory(a.truth_path, a.frames_unit);
    ev::requireRigidMotions(est.poses, a.estimate_path); // named by file, before pairing
    ev::requireRigidMotions(truth.poses, a.truth_path);
    const ev::PairedTrajectories paired =
        ev::pairTrajectories(est, a.estimate_path, truth, a.truth_path, a.max_diff, a.truncate);
    printResult(out,
                a,
                est,
                truth,
                paired.association,
                ev::evaluateTrajectory(paired.estimate, paired.truth, eo));
    return 0;
  }
  catch (const std::exception& ex) {
    err << "pcl_pslam evaluate: " << ex.what() << '\n';
    return 1;
  }
}

} // namespace pcl_pslam
