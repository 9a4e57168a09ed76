/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "simulate_command.h"

#include <pcl_parallel/sim/presets.h>
#include <pcl_parallel/sim/scan_set_writer.h>

#include <boost/program_options.hpp>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <iterator>
#include <utility>

namespace pcl_pslam {

namespace po = boost::program_options;

int
simulateCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err)
{
  std::string preset, dir, format = "auto";
  std::uint32_t seed = 1;
  unsigned threads = 0;
  int beams = 0;
  po::options_description visible("simulate options");
  visible.add_options()("preset,p",
                        po::value(&preset)->value_name("NAME"),
                        "office, hannover, riegl or kitti (see --list)")(
      "seed", po::value(&seed)->default_value(1), "random seed; the same seed, the same files")(
      "format,f",
      po::value(&format)->value_name("F")->default_value("auto"),
      "auto (uos for stop-and-go presets, kitti for kitti), uos, kitti (NNNNNN.bin), or pcd "
      "(NNNNNN.pcd with each point's time in a uint32 field t, ns from the sweep's start, as "
      "Ouster's driver writes it)")(
      "beams",
      po::value(&beams)->default_value(0),
      "beams (rows) of the scanner over the preset's field of view, e.g. 16 with kitti for a "
      "VLP-16-like sparse lidar; 0 = the preset's")(
      "threads,t", po::value(&threads)->default_value(0), "threads, 0 = all cores")(
      "list", "the presets, one line each")("help,h", "this text");
  po::options_description all;
  all.add(visible).add_options()("dir", po::value(&dir));
  po::positional_options_description positional;
  positional.add("dir", 1);
  const std::string usage =
      "usage: pcl_pslam simulate --preset NAME [--seed N] [--format F] [--beams N] OUT_DIR\n";
  po::variables_map vm;
  try {
    po::store(po::command_line_parser(args).options(all).positional(positional).run(), vm);
    po::notify(vm);
  }
  catch (const po::error& e) {
    err << "pcl_pslam simulate: " << e.what() << '\n';
    return 2;
  }
  if (vm.count("help")) {
    out << usage
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
  if (preset.empty() || dir.empty()) {
    err << "pcl_pslam simulate: needs --preset NAME and OUT_DIR\n" << usage;
    return 2;
  }
  const auto names = pcl_parallel::sim::presetNames();
  if (std::find(names.begin(), names.end(), preset) == names.end()) {
    err << "pcl_pslam simulate: unknown preset '" << preset << "' (see --list)\n";
    return 2;
  }
  using pcl_parallel::sim::ScanSetFormat;
  const std::pair<const char*, ScanSetFormat> formats[] = {{"auto", ScanSetFormat::Auto},
                                                           {"uos", ScanSetFormat::Uos},
                                                           {"kitti", ScanSetFormat::Kitti},
                                                           {"pcd", ScanSetFormat::Pcd}};
  const auto chosen = std::find_if(
      std::begin(formats), std::end(formats), [&](const auto& f) { return format == f.first; });
  if (chosen == std::end(formats)) {
    err << "pcl_pslam simulate: unknown --format '" << format << "' (auto, uos, kitti, pcd)\n";
    return 2;
  }
  if (beams < 0 || beams == 1) {
    err << "pcl_pslam simulate: --beams must be 0 (the preset's) or at least 2, got " << beams
        << '\n';
    return 2;
  }
  try {
    const auto start = std::chrono::steady_clock::now();
    pcl_parallel::sim::PresetOptions options;
    options.seed = seed;
    options.num_threads = threads;
    options.beams = beams;
    const auto set = pcl_parallel::sim::simulatePreset(preset, options);
    pcl_parallel::sim::writeScanSet(set, dir, chosen->second);
    std::size_t points = 0;
    for (const auto& s : set.scans)
      points += s->size();
    out << "simulate: " << preset << " (seed " << seed << "): " << set.scans.size()
        << " scans, " << points << " points, written to " << dir << " in "
        << std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()
        << " s\n";
  }
  catch (const std::exception& e) {
    err << "pcl_pslam simulate: " << e.what() << '\n';
    return 1;
  }
  return 0;
}

} // namespace pcl_pslam
