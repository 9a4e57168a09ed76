/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pcl_pslam: 6D SLAM with pICP and pLUM (the paper's pipeline) on a directory of scans,
 * or on the built-in simulated scan set (`pcl_pslam demo`).
 */
#include "slam_pipeline.h"

#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/uos.h>
#include <pcl_parallel/sim/simulated_scans.h>

#include <pcl/console/print.h>
#include <pcl/io/pcd_io.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <stdexcept>
#include <string>

namespace fs = std::filesystem;

namespace {

constexpr double kDeg = M_PI / 180.0;

void
usage()
{
  std::printf(
      "usage: pcl_pslam demo [options]          the built-in simulated scan set\n"
      "       pcl_pslam run DIR [options]       the scans in DIR, in file-name order\n"
      "\n"
      "DIR holds one file per scan: 3DTK uos (.3d, with .pose odometry beside it),\n"
      ".pcd, .ply, .xyz/.txt (x y z per line) or KITTI .bin. Without .pose files the\n"
      "initial poses come from --poses FILE (KITTI poses.txt: 12 numbers per line) or,\n"
      "failing that, a constant-velocity guess.\n"
      "\n"
      "options:\n"
      "  --out DIR            where results go (default: pcl_pslam_out)\n"
      "  --threads N          threads, 0 = all cores (default 0)\n"
      "  --voxel M            voxel size of the reduction, metres (default 0.1)\n"
      "  --icp-distance M     pICP correspondence distance (default 0.5)\n"
      "  --icp-iterations N   pICP iteration cap (default 100)\n"
      "  --loop-distance M    link scans closer than this (default 3)\n"
      "  --loop-size N        ... that are at least N scans apart (default 10)\n"
      "  --lum-distance M     pLUM gate of the first iteration (default 1.0)\n"
      "  --lum-final M        pLUM gate it shrinks to (default 0.2)\n"
      "  --lum-iterations N   pLUM iteration cap (default 30)\n"
      "  --min-range R        drop points closer to the scanner, in the files' units\n"
      "                       (run; default 0)\n"
      "  --max-range R        drop points farther away (run; default: none)\n"
      "  --scale S            multiply coordinates by S (run; default 1, .3d: 0.01,\n"
      "                       3DTK's centimetres to metres)\n"
      "  --poses FILE         initial poses (run; KITTI poses.txt format)\n"
      "  --format EXT         read only *.EXT (run; default: the most common scan\n"
      "                       extension in DIR; .txt only when given here)\n"
      "  --up x|y|z           the vertical axis of the picture (default z, .3d: y)\n"
      "  --quiet              no progress lines\n"
      "\n"
      "writes: poses_icp.txt, poses.txt (KITTI format, after pICP and after pLUM),\n"
      "map.pcd (merged, reduced map) and map.png (top view with the trajectory).\n");
}

struct Options {
  std::string command, dir, out = "pcl_pslam_out", poses_file, format;
  pcl_pslam::Parameters params;
  double min_range = 0.0, max_range = std::numeric_limits<double>::infinity();
  double scale = 0.0; // 0: per format
  int up = -1;        // -1: per format
  bool quiet = false;
};

std::string
lowerCase(std::string s)
{
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  return s;
}

double
number(const std::string& flag, const char* text)
{
  char* end = nullptr;
  const double v = std::strtod(text, &end);
  if (end == text || *end != '\0' || !std::isfinite(v))
    throw std::invalid_argument(flag + " needs a number, got '" + text + "'");
  return v;
}

int
integer(const std::string& flag, const char* text, int min_value)
{
  const double v = number(flag, text);
  if (v != std::floor(v) || v < min_value || v > 1e9)
    throw std::invalid_argument(flag + " needs a whole number >= " + std::to_string(min_value) +
                                ", got '" + text + "'");
  return static_cast<int>(v);
}

Options
parse(int argc, char** argv)
{
  Options o;
  if (argc < 2)
    throw std::invalid_argument("no command");
  o.command = argv[1];
  int i = 2;
  if (o.command == "run") {
    if (argc < 3)
      throw std::invalid_argument("run needs a directory");
    o.dir = argv[i++];
  }
  else if (o.command != "demo")
    throw std::invalid_argument("unknown command '" + o.command + "'");
  for (; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--quiet") {
      o.quiet = true;
      continue;
    }
    if (a == "--no-loops") {
      o.params.close_loops = false;
      continue;
    }
    if (a == "--deskew" || a == "--scan-to-scan") {
      (a == "--deskew" ? o.params.deskew : o.params.scan_to_scan) = true;
      continue;
    }
    if (i + 1 >= argc)
      throw std::invalid_argument(a + " needs a value");
    const char* v = argv[++i];
    auto positive = [&](double x) {
      if (!(x > 0.0))
        throw std::invalid_argument(a + " must be positive");
      return x;
    };
    if (a == "--out")
      o.out = v;
    else if (a == "--threads")
      o.params.num_threads = static_cast<unsigned>(integer(a, v, 0));
    else if (a == "--voxel")
      o.params.voxel_size = number(a, v);
    else if (a == "--icp-distance")
      o.params.icp_distance = number(a, v);
    else if (a == "--icp-iterations")
      o.params.icp_iterations = integer(a, v, 1);
    else if (a == "--loop-distance")
      o.params.loop_distance = number(a, v);
    else if (a == "--loop-size")
      o.params.loop_size = integer(a, v, 1);
    else if (a == "--lum-distance")
      o.params.lum_distance = number(a, v);
    else if (a == "--lum-final")
      o.params.lum_final_distance = positive(number(a, v));
    else if (a == "--lum-iterations")
      o.params.lum_iterations = integer(a, v, 1);
    else if (a == "--min-range")
      o.min_range = number(a, v);
    else if (a == "--max-range")
      o.max_range = positive(number(a, v));
    else if (a == "--scale")
      o.scale = positive(number(a, v));
    else if (a == "--poses")
      o.poses_file = v;
    else if (a == "--format") {
      o.format = lowerCase(v);
      if (!pcl_parallel::io::isScanFile("x." + o.format))
        throw std::invalid_argument("--format: unknown scan format '" + std::string(v) + "'");
    }
    else if (a == "--up") {
      const std::string axis = v;
      if (axis != "x" && axis != "y" && axis != "z")
        throw std::invalid_argument("--up needs x, y or z");
      o.up = axis[0] - 'x';
    }
    else
      throw std::invalid_argument("unknown option " + a);
  }
  return o;
}

/** The scans of a directory in file-name order, with initial poses. */
void
loadDirectory(Options& o, std::vector<pcl_pslam::Cloud::Ptr>& scans, pcl_pslam::Poses& poses)
{
  if (!fs::is_directory(o.dir))
    throw std::runtime_error(o.dir + " is not a directory");
  // One format per directory: --format, else the most common scan extension (.txt only
  // when asked for: it also names notes and pose lists).
  std::map<std::string, std::vector<fs::path>> by_ext;
  for (const auto& e : fs::directory_iterator(o.dir))
    if (e.is_regular_file() && pcl_parallel::io::isScanFile(e.path().string())) {
      by_ext[lowerCase(e.path().extension().string().substr(1))].push_back(e.path());
    }
  std::string format = o.format;
  if (format.empty()) {
    std::size_t best = 0;
    for (const auto& [ext, list] : by_ext) {
      if (ext == "txt")
        continue;
      if (list.size() > best)
        best = list.size(), format = ext;
      else if (list.size() == best && best > 0)
        throw std::runtime_error(o.dir + " holds " + std::to_string(best) + " ." + format +
                                 " and " + std::to_string(best) + " ." + ext +
                                 " files; choose one with --format");
    }
  }
  std::vector<fs::path> files = by_ext[format];
  std::sort(files.begin(), files.end());
  if (files.size() < 2)
    throw std::runtime_error(o.dir + " holds " + std::to_string(files.size()) + " scan files" +
                             (format.empty() ? "" : " (." + format + ")") +
                             "; pcl_pslam needs at least 2");
  const bool uos = format == "3d";
  if (o.scale == 0.0)
    o.scale = uos ? 0.01 : 1.0;
  if (o.up < 0)
    o.up = uos ? 1 : 2;
  // Range limits are in the file's units, like the coordinates they filter.
  for (const auto& f : files) {
    auto cloud = pcl_parallel::io::loadScan(f.string(), o.min_range, o.max_range);
    for (auto& p : *cloud)
      p.getVector3fMap() *= static_cast<float>(o.scale);
    scans.push_back(cloud);
    if (uos) {
      fs::path pose = f;
      pose.replace_extension(".pose");
      if (fs::exists(pose)) {
        Eigen::Matrix4d m = pcl_parallel::io::loadUosPose(pose.string());
        m.topRightCorner<3, 1>() *= o.scale;
        poses.push_back(m);
      }
    }
    if (!o.quiet)
      std::printf("\rread %zu / %zu scans", scans.size(), files.size()), std::fflush(stdout);
  }
  if (!o.quiet)
    std::printf("\n");
  if (!o.poses_file.empty()) {
    poses = pcl_parallel::io::loadKittiPoses(o.poses_file);
    for (auto& m : poses)
      m.topRightCorner<3, 1>() *= o.scale;
  }
  if (!poses.empty() && poses.size() != scans.size())
    throw std::runtime_error(std::to_string(poses.size()) + " initial poses for " +
                             std::to_string(scans.size()) + " scans");
  if (poses.empty()) { // no odometry: constant-velocity guesses
    poses.assign(scans.size(), Eigen::Matrix4d::Identity());
    o.params.odometry = false;
    std::printf("no initial poses: pICP starts each scan from the previous step\n");
  }
}

void
printErrors(const char* what, const pcl_pslam::Poses& poses, const pcl_pslam::Poses& truth)
{
  const auto e = pcl_pslam::poseErrors(poses, truth);
  std::printf("  %-10s max %7.3f m %6.2f deg   mean %7.3f m %6.2f deg\n",
              what,
              e.max_trans,
              e.max_rot / kDeg,
              e.mean_trans,
              e.mean_rot / kDeg);
}

} // namespace

int
main(int argc, char** argv)
{
  Options o;
  try {
    o = parse(argc, argv);
  }
  catch (const std::exception& e) {
    std::fprintf(stderr, "pcl_pslam: %s\n\n", e.what());
    usage();
    return 2;
  }
  pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
  try {
    const auto start = std::chrono::steady_clock::now();
    std::vector<pcl_pslam::Cloud::Ptr> scans;
    pcl_pslam::Poses initial, truth;
    if (o.command == "demo") {
      pcl_parallel::sim::SimulationParameters sp;
      std::printf("simulating a %.0f x %.0f m floor, %.1f laps of its corridor...\n",
                  sp.outer_length,
                  sp.outer_width,
                  sp.laps);
      const auto set = pcl_parallel::sim::simulateScanSet(sp, o.params.num_threads);
      scans = set.scans;
      initial = set.odometry;
      truth = set.truth;
      if (o.up < 0)
        o.up = 2;
    }
    else
      loadDirectory(o, scans, initial);
    std::size_t points = 0;
    for (const auto& s : scans)
      points += s->size();
    std::printf("%zu scans, %zu points\n", scans.size(), points);

    pcl_pslam::Progress progress;
    if (!o.quiet)
      progress = [](const std::string& stage, int done, int total) {
        std::printf("\r%-6s %4d / %d", stage.c_str(), done, total);
        if (done == total || stage == "lum")
          std::printf("\n");
        std::fflush(stdout);
      };
    const pcl_pslam::Result r = pcl_pslam::run(scans, initial, o.params, progress);
    if (r.icp_failures > 0)
      std::printf("pICP: %d of %zu matches did not converge; their odometry steps were kept\n",
                  r.icp_failures,
                  scans.size() - 1);
    std::printf("pLUM: %zu links, %d iterations\n", r.links.size(), r.lum_iterations);

    fs::create_directories(o.out);
    pcl_pslam::writePoses((fs::path(o.out) / "poses_icp.txt").string(), r.icp);
    pcl_pslam::writePoses((fs::path(o.out) / "poses.txt").string(), r.final);
    const auto map = pcl_pslam::mergedMap(scans, r.final, o.params.voxel_size);
    const std::string map_path = (fs::path(o.out) / "map.pcd").string();
    if (pcl::io::savePCDFileBinary(map_path, *map) < 0)
      throw std::runtime_error("cannot write " + map_path);
    pcl_pslam::writeTopView((fs::path(o.out) / "map.png").string(), *map, r.final, o.up);
    if (!truth.empty()) {
      std::printf("pose errors against the simulation's truth:\n");
      printErrors("odometry", initial, truth);
      printErrors("pICP", r.icp, truth);
      printErrors("pLUM", r.final, truth);
    }
    std::printf(
        "wrote %s/{poses_icp.txt, poses.txt, map.pcd, map.png} (%zu map points) in "
        "%.1f s\n",
        o.out.c_str(),
        map->size(),
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  catch (const std::exception& e) {
    std::fprintf(stderr, "pcl_pslam: %s\n", e.what());
    return 1;
  }
  return 0;
}
