/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * libFuzzer harness for our file readers (issue 11): the shared part, compiled once. Each
 * fuzz_<format> executable is fuzz_main.cpp with PCL_PARALLEL_FUZZ_FORMAT="<format>"
 * (test/fuzz/CMakeLists.txt). The readers take a path, so each input is written to a
 * private file with the reader's extension first.
 * Contract under test: a reader returns or throws std::exception (our std::runtime_error,
 * std::invalid_argument, std::out_of_range); anything else (a crash, an ASan/UBSan report,
 * a hang, an allocation beyond -malloc_limit_mb, a non-finite point in the cloud) is a bug.
 */
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/stanford.h>
#include <pcl_parallel/io/uos.h>

#include <pcl/console/print.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <unistd.h>
#include <utility>

namespace pcl_parallel_fuzz {

namespace {

std::string format_name, extension, input_path;

void
checkCloud(const pcl::PointCloud<pcl::PointXYZ>& cloud)
{
  // The readers promise an unorganised dense cloud of finite points.
  if (cloud.width != cloud.size() || cloud.height != 1 || !cloud.is_dense)
    std::abort();
  for (const auto& p : cloud)
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      std::abort();
}

void
read(const std::string& path)
{
  using namespace pcl_parallel::io;
  if (format_name == "uos_pose") {
    if (!loadUosPose(path).allFinite())
      std::abort();
  }
  else if (format_name == "frames") {
    if (!loadFramesFinalPose(path).allFinite())
      std::abort();
  }
  else if (format_name == "kitti_poses") {
    for (const auto& pose : loadKittiPoses(path))
      if (!pose.allFinite())
        std::abort();
  }
  else if (format_name == "stanford_conf") {
    for (const auto& entry : loadStanfordConf(path))
      if (!entry.pose.allFinite())
        std::abort();
  }
  else {
    // The scan formats through loadScan (the extension picks the reader), once unfiltered
    // and once with a range filter.
    checkCloud(*loadScan(path));
    checkCloud(*loadScan(path, 0.5, 100.0));
  }
}

} // namespace

void
initialize(const char* format)
{
  static const std::pair<const char*, const char*> kFormats[] = {{"uos_scan", ".3d"},
                                                                 {"uos_pose", ".pose"},
                                                                 {"frames", ".frames"},
                                                                 {"xyz", ".xyz"},
                                                                 {"kitti_scan", ".bin"},
                                                                 {"kitti_poses", ".txt"},
                                                                 {"stanford_conf", ".conf"},
                                                                 {"pcd", ".pcd"},
                                                                 {"ply", ".ply"}};
  format_name = format;
  for (const auto& [name, ext] : kFormats)
    if (format_name == name)
      extension = ext;
  if (extension.empty())
    std::abort(); // a harness built for a format this file does not know
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); // PCL's readers print a lot
  const std::filesystem::path dir =
      std::filesystem::exists("/dev/shm") ? "/dev/shm" : std::filesystem::temp_directory_path();
  input_path = (dir / ("pcl_parallel_fuzz_" + std::to_string(::getpid()) + extension)).string();
  std::atexit([] { std::remove(input_path.c_str()); });
}

void
testOneInput(const std::uint8_t* data, std::size_t size)
{
  {
    std::ofstream out(input_path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    read(input_path);
  }
  catch (const std::exception&) {
    // A clear error is the expected answer to a bad file.
  }
}

} // namespace pcl_parallel_fuzz
