/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "arguments.h"
#include "progress.h"
#include "simulate_command.h"

#include <pcl_parallel/io/output_directory.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/sim/scan_set_writer.h>

#include <algorithm>
#include <chrono>
#include <stdexcept>
#include <string>

namespace pcl_pslam {

namespace po = boost::program_options;

namespace {

using pcl_parallel::sim::ScanSetFormat;

/** What `simulate` is told. */
struct SimulateArguments {
  std::string preset, dir, format = "auto";
  pcl_parallel::sim::PresetOptions options; ///< seed, threads, beams
};

const char* const kUsage =
    "usage: pcl_pslam simulate --preset NAME [--seed N] [--format F] [--beams N] OUT_DIR\n";

/** `simulate`'s options, bound to `a`. */
po::options_description
simulateOptions(SimulateArguments& a)
{
  po::options_description visible("simulate options");
  auto add = visible.add_options();
  add("preset,p",
      po::value(&a.preset)->value_name("NAME"),
      "office, hannover, riegl or kitti (see --list)");
  add("seed",
      po::value(&a.options.seed)->default_value(1),
      "random seed; the same seed, the same files");
  add("format,f",
      po::value(&a.format)->value_name("F")->default_value("auto"),
      "auto (uos for stop-and-go presets, kitti for kitti), uos, kitti (NNNNNN.bin), or pcd "
      "(NNNNNN.pcd with each point's time in a uint32 field t, ns from the sweep's start, as "
      "Ouster's driver writes it)");
  add("beams",
      po::value(&a.options.beams)->default_value(0),
      "beams (rows) of the scanner over the preset's field of view, e.g. 16 with kitti for a "
      "VLP-16-like sparse lidar; 2 to 4096, 0 = the preset's");
  add("threads,t",
      po::value(&a.options.num_threads)->default_value(0),
      "threads, 0 = all cores, at most 1024");
  add("list", "the presets, one line each");
  add("help,h", "this text");
  return visible;
}

/** The checked preset and format, or a message for a usage error. */
std::string
checkSimulateArguments(const SimulateArguments& a, ScanSetFormat& format)
{
  if (a.preset.empty() || a.dir.empty())
    return std::string("needs --preset NAME and OUT_DIR\n") + kUsage;
  const auto names = pcl_parallel::sim::presetNames();
  if (std::find(names.begin(), names.end(), a.preset) == names.end())
    return "unknown preset '" + a.preset + "' (see --list)\n";
  try {
    format = pcl_parallel::sim::scanSetFormatFromString(a.format);
  }
  catch (const std::invalid_argument&) {
    return "unknown --format '" + a.format + "' (auto, uos, kitti, pcd)\n";
  }
  if (a.options.beams < 0 || a.options.beams == 1 || a.options.beams > 4096) // 64x a Velodyne's
    return "--beams must be 0 (the preset's) or 2 to 4096, got " +
           std::to_string(a.options.beams) + '\n';
  if (a.options.num_threads > pcl_parallel::kMaxThreads)
    return "--threads takes 0 (all cores) to " + std::to_string(pcl_parallel::kMaxThreads) +
           ", got " + std::to_string(a.options.num_threads) + '\n';
  return {};
}

/** Simulates and writes the set into a temporary directory swapped in for OUT_DIR (one
 *  unit: OUT_DIR holds this set or what it held before, whatever ends the command); a line
 *  about it on `out`. */
void
simulateAndWrite(const SimulateArguments& a, ScanSetFormat format, std::ostream& out)
{
  const auto start = std::chrono::steady_clock::now();
  pcl_parallel::io::OutputDirectory dir(a.dir, pcl_parallel::sim::isScanSetName);
  pcl_parallel::sim::ScanSetSummary set;
  try {
    set = pcl_parallel::sim::simulateToDirectory(a.preset, a.options, dir.path(), format);
  }
  catch (const std::exception& e) { // named by OUT_DIR's file, not its temporary's
    throw std::runtime_error(dir.inTarget(e.what()));
  }
  dir.commit();
  out << "simulate: " << a.preset << " (seed " << a.options.seed << "): " << set.scans
      << " scans, " << set.points << " points, written to " << a.dir << " in "
      << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() << " s"
      << (dir.replacesEarlierRun() ? ", replacing the scan set there" : "") << "\n";
}

} // namespace

int
simulateCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err)
{
  SimulateArguments a;
  const po::options_description visible = simulateOptions(a);
  po::options_description all;
  all.add(visible).add_options()("dir", po::value(&a.dir));
  po::positional_options_description positional;
  positional.add("dir", 1);
  po::variables_map vm;
  try {
    vm = parseArguments(args, all, positional);
  }
  catch (const po::error& e) {
    err << "pcl_pslam simulate: " << optionErrorMessage(e, args) << '\n';
    return 2;
  }
  if (vm.count("help")) {
    out << kUsage
        << "\nWrites the scans (uos scanNNN.3d + .pose for stop-and-go presets, "
           "KITTI NNNNNN.bin + odometry.txt + times.txt for kitti; --format to choose) and "
           "ground_truth.txt (KITTI poses) into OUT_DIR, which `pcl_pslam run "
           "OUT_DIR` reads back.\n\n"
        << visible;
    return 0;
  }
  if (vm.count("list")) {
    for (const auto& name : pcl_parallel::sim::presetNames())
      out << name << ": " << pcl_parallel::sim::presetDescription(name) << '\n';
    return 0;
  }
  ScanSetFormat format = ScanSetFormat::Auto;
  if (const std::string problem = checkSimulateArguments(a, format); !problem.empty()) {
    err << "pcl_pslam simulate: " << problem;
    return 2;
  }
  installSignalHandlers();
  try {
    simulateAndWrite(a, format, out);
  }
  catch (const pcl_parallel::io::OutputDirectoryError& e) {
    err << "pcl_pslam simulate: OUT_DIR " << e.what() << '\n';
    return 2;
  }
  catch (const std::exception& e) {
    err << "pcl_pslam simulate: " << e.what() << '\n';
    return 1;
  }
  return 0;
}

} // namespace pcl_pslam
