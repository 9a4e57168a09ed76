/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "arguments.h"
#include "evaluate_command.h"
#include "options.h" // UsageError

#include <pcl_parallel/evaluation/relations.h>
#include <pcl_parallel/evaluation/report.h>

#include <filesystem>
#include <stdexcept>

namespace pcl_pslam {

namespace po = boost::program_options;
namespace ev = pcl_parallel::evaluation;

namespace {

constexpr const char* kUsage =
    "usage: pcl_pslam evaluate ESTIMATE GROUND_TRUTH [options]\n"
    "       pcl_pslam evaluate ESTIMATE --relations FILE [--max-diff S] [--json]\n"
    "\n"
    "Absolute trajectory error (ATE, as evo_ape) and relative pose errors (per frame as\n"
    "evo_rpe, over path lengths as the KITTI odometry devkit) of ESTIMATE against\n"
    "GROUND_TRUTH. Each is a KITTI poses file (12 numbers a line), a TUM file (timestamp\n"
    "tx ty tz qx qy qz qw) or a directory of 3DTK scanNNN.frames. Poses are paired by\n"
    "timestamp when both files have them, else by index.\n"
    "\n"
    "With --relations, ESTIMATE (a TUM file) is measured against the relative motions of\n"
    "a Freiburg .relations file (Kuemmerle et al., Autonomous Robots 2009): mean and std\n"
    "of the translational and rotational errors, absolute and squared.\n";

/** What `evaluate` is told. */
struct EvaluateArguments {
  std::string estimate_path, truth_path, relations_path, align = "se3", lengths_text = "auto";
  std::size_t step = 10, delta = 1;
  ev::FileEvaluationOptions files;
  bool as_json = false;
};

/** `evaluate`'s options, bound to `a`. */
po::options_description
evaluateOptions(EvaluateArguments& a)
{
  po::options_description options("options");
  auto add = options.add_options();
  add("help,h", "this text");
  add("json", po::bool_switch(&a.as_json), "print JSON instead of a table");
  add("align",
      po::value(&a.align)->default_value(a.align),
      "alignment before the ATE: none, se3 (rigid, evo_ape --align) or sim3 (with scale, "
      "--correct_scale; also rescales the RPE)");
  add("lengths",
      po::value(&a.lengths_text)->default_value(a.lengths_text),
      "KITTI RPE segment lengths in metres, comma-separated; kitti = the devkit's "
      "100,...,800; auto = the devkit's when the ground truth's path is longer than 800 m, "
      "else 10%,...,80% of its length");
  add("step",
      po::value(&a.step)->default_value(a.step),
      "KITTI RPE: frames between segment starts");
  add("delta",
      po::value(&a.delta)->default_value(a.delta),
      "per-frame RPE: frames between pairs");
  add("max-diff",
      po::value(&a.files.max_diff)->default_value(a.files.max_diff),
      "largest timestamp difference (s) of an associated pair (evo's --t_max_diff)");
  add("frames-unit",
      po::value(&a.files.frames_unit)->default_value(a.files.frames_unit),
      "metres per unit of .frames translations (3DTK: centimetres, 0.01)");
  add("truncate",
      po::bool_switch(&a.files.truncate),
      "pairing by index: compare the first min(n, m) poses when the counts differ (else an "
      "error)");
  add("relations",
      po::value(&a.relations_path),
      "a Freiburg .relations file (t1 t2 x y z roll pitch yaw a line): the relation error "
      "of ESTIMATE (Kuemmerle et al. 2009) instead of the errors against GROUND_TRUTH; "
      "times match within --max-diff");
  return options;
}

/** Runs a library parser on an option's text; its std::invalid_argument is a UsageError. */
template <typename Parse>
auto
parseOption(const char* option, const std::string& text, Parse parse)
{
  try {
    return parse(text);
  }
  catch (const std::invalid_argument& e) {
    throw UsageError(std::string(option) + ": " + e.what());
  }
}

/** Parses and checks `args` into `a`; false where --help was answered. Throws po::error or
 *  UsageError. */
bool
parseEvaluateArguments(const std::vector<std::string>& args,
                       EvaluateArguments& a,
                       std::ostream& out)
{
  const po::options_description options = evaluateOptions(a);
  po::options_description all;
  all.add(options).add_options()("estimate", po::value(&a.estimate_path))(
      "ground-truth", po::value(&a.truth_path));
  po::positional_options_description positional;
  positional.add("estimate", 1).add("ground-truth", 1);
  const po::variables_map vm = parseArguments(args, all, positional);
  if (vm.count("help")) {
    out << kUsage << '\n' << options;
    return false;
  }
  const bool relations = vm.count("relations") > 0;
  if (relations &&
      (a.estimate_path.empty() || !a.truth_path.empty() || a.relations_path.empty()))
    throw UsageError("--relations FILE needs ESTIMATE and no GROUND_TRUTH");
  if (!relations && (a.estimate_path.empty() || a.truth_path.empty()))
    throw UsageError("needs ESTIMATE and GROUND_TRUTH");
  for (const std::string& path : {a.estimate_path, relations ? a.relations_path : a.truth_path})
    if (std::error_code ec; !std::filesystem::exists(path, ec)) // as run's missing DIR
      throw UsageError(path + ": no such file or directory");
  ev::EvaluationOptions& eo = a.files.evaluation;
  eo.alignment = parseOption("--align", a.align, ev::alignmentFromString);
  eo.kitti_lengths = parseOption("--lengths", a.lengths_text, ev::kittiLengthsFromString);
  constexpr std::size_t kMaxFrames = 1000000000; // a negative count wraps far beyond
  if (a.step == 0 || a.delta == 0 || a.step > kMaxFrames || a.delta > kMaxFrames)
    throw UsageError("--step and --delta take a frame count from 1 to 1e9");
  if (!(a.files.max_diff >= 0.0) || !(a.files.frames_unit > 0.0))
    throw UsageError("--max-diff must be >= 0 and --frames-unit > 0");
  eo.kitti_step = a.step;
  eo.rpe_delta = a.delta;
  return true;
}

} // namespace

int
evaluateCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err)
{
  EvaluateArguments a;
  try {
    if (!parseEvaluateArguments(args, a, out))
      return 0;
  }
  catch (const std::exception& e) { // po::error or UsageError
    const auto* option = dynamic_cast<const po::error*>(&e);
    err << "pcl_pslam evaluate: " << (option ? optionErrorMessage(*option, args) : e.what())
        << " (pcl_pslam evaluate --help)\n";
    return 2;
  }
  try {
    if (!a.relations_path.empty()) {
      const ev::RelationFileEvaluation e = ev::evaluateRelationsFile(
          a.estimate_path, a.relations_path, a.files.max_diff, a.files.frames_unit);
      if (a.as_json)
        out << ev::toJson(e) << '\n';
      else
        ev::printRelationEvaluation(out, e);
      return 0;
    }
    const ev::FileEvaluation e = ev::evaluateFiles(a.estimate_path, a.truth_path, a.files);
    if (a.as_json)
      out << ev::toJson(e) << '\n';
    else
      ev::printFileEvaluation(out, e);
    return 0;
  }
  catch (const std::exception& ex) {
    err << "pcl_pslam evaluate: " << ex.what() << '\n';
    return 1;
  }
}

} // namespace pcl_pslam
