/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "detail.h"

#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/uos.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string_view>
#include <system_error>
#include <vector>

namespace pcl_parallel {
namespace io {

namespace {

using detail::fail;
using detail::openOrThrow;

using detail::Fields;
using detail::parseNumber;

std::string
inQuotes(std::string_view s)
{
  return detail::quoted(s);
}

/** Checked before a reader opens the file: PCL's readers print their own error for a
 *  missing file, and a directory opens as a stream whose "size" is meaningless. */
void
requireRegularFile(const std::string& path)
{
  std::error_code ec;
  const std::filesystem::file_status st = std::filesystem::status(path, ec);
  if (st.type() == std::filesystem::file_type::not_found)
    fail(path, 0, "no such file");
  if (ec)
    fail(path, 0, "cannot access file: " + ec.message());
  if (!std::filesystem::is_regular_file(st))
    fail(path, 0, "not a regular file");
}

enum class Format { Uos, Xyz, Kitti, Pcd, Ply };

struct Extension {
  const char* name; ///< lower case, with the dot
  Format format;
};

// The one list of what loadScan reads: isScanFile and the error message follow it.
constexpr Extension kExtensions[] = {{".3d", Format::Uos},
                                     {".xyz", Format::Xyz},
                                     {".txt", Format::Xyz},
                                     {".bin", Format::Kitti},
                                     {".pcd", Format::Pcd},
                                     {".ply", Format::Ply}};

const Extension*
findExtension(const std::string& path)
{
  const std::string ext = detail::lowerCaseExtension(path);
  for (const Extension& e : kExtensions)
    if (ext == e.name)
      return &e;
  return nullptr;
}

/** KITTI plausibility (the format has no header or magic number, so only the values can
 *  tell): a Velodyne HDL-64E reports up to 120 m (KITTI, Geiger et al. 2013), so a finite
 *  coordinate or reflectance beyond kKittiMaxValue is not a KITTI scan (NaN and inf mark a
 *  no-return, dropped as in every format), and
 *  a file where most points have all three coordinates nonzero below kKittiTiny (1 mm from
 *  the sensor, inside its minimum range) is text read as floats: digits, spaces, signs,
 *  points and line ends as the high byte of a float32 give 1e-19..2.4e-4. */
constexpr float kKittiMaxValue = 1e5f;
constexpr float kKittiTiny = 1e-3f;

bool
tinyNonZero(float v)
{
  return v != 0.0f && std::abs(v) < kKittiTiny;
}

} // namespace

pcl::PointCloud<pcl::PointXYZ>::Ptr
loadXyzScan(const std::string& path, double min_range, double max_range)
{
  detail::RangeFilteredCloud cloud(path, min_range, max_range);
  std::size_t points = 0;
  detail::forEachLine(path, [&](const std::string& line, std::size_t line_no) {
    if (line[line.find_first_not_of(detail::kSpace)] == '#')
      return;
    ++points;
    Fields fields(line);
    double v[3];
    for (int k = 0; k < 3; ++k) {
      std::string_view field;
      if (!fields.next(field))
        fail(path, line_no, "expected three numbers \"x y z\", got " + inQuotes(line));
      if (!parseNumber(field, v[k]))
        fail(path,
             line_no,
             "column " + std::to_string(k + 1) + " is not a number: " + inQuotes(field));
    }
    cloud.add(v[0], v[1], v[2], line_no);
  });
  if (points == 0)
    fail(path, 0, "no points (an empty or comment-only file)");
  return cloud.finish();
}

pcl::PointCloud<pcl::PointXYZ>::Ptr
loadKittiScan(const std::string& path, double min_range, double max_range)
{
  constexpr std::streamoff kRecordBytes = 16; // x, y, z, reflectance
  requireRegularFile(path);
  std::ifstream in = openOrThrow(path, std::ios::in | std::ios::binary);
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  in.seekg(0, std::ios::beg);
  if (!in || size < 0)
    fail(path, 0, "cannot determine the file size");
  if (size % kRecordBytes != 0)
    fail(path,
         0,
         "truncated: size " + std::to_string(size) +
             " bytes is not a multiple of 16 (float32 x, y, z, reflectance a point)");
  std::vector<unsigned char> bytes;
  detail::guardAllocation(path, [&] { bytes.resize(static_cast<std::size_t>(size)); });
  if (size > 0 && !in.read(reinterpret_cast<char*>(bytes.data()), size))
    fail(path, 0, "read error");
  // Impossible as KITTI records: as float32 "ply\n" is 1e-32, "# .P" 1e10.
  if (size >= 4 &&
      (std::memcmp(bytes.data(), "ply\n", 4) == 0 || std::memcmp(bytes.data(), "# .P", 4) == 0))
    fail(path, 0, "starts like a PCD or PLY header, not KITTI float32 records");
  const std::size_t n = bytes.size() / kRecordBytes;
  detail::RangeFilteredCloud cloud(path, min_range, max_range);
  cloud.reserve(n);
  std::size_t tiny = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char* record = bytes.data() + i * kRecordBytes;
    float v[4];
    for (int a = 0; a < 4; ++a) {
      v[a] = static_cast<float>(detail::binaryValue(record + 4 * a, {'F', 4})); // little-endian
      if (std::isfinite(v[a]) && std::abs(v[a]) > kKittiMaxValue)
        fail(path,
             0,
             "point " + std::to_string(i + 1) + ": value " + std::to_string(v[a]) +
                 " is not a plausible KITTI coordinate or reflectance (|v| <= 1e5)");
    }
    tiny += tinyNonZero(v[0]) && tinyNonZero(v[1]) && tinyNonZero(v[2]);
    cloud.add(v[0], v[1], v[2], i + 1);
  }
  if (n > 0 && 2 * tiny > n)
    fail(path,
         0,
         std::to_string(tiny) + " of " + std::to_string(n) +
             " points have all coordinates below 1 mm: not KITTI float32 "
             "records (text, or other bytes?)");
  return cloud.finish();
}

std::vector<Eigen::Matrix4d>
loadKittiPoses(const std::string& path)
{
  std::vector<Eigen::Matrix4d> poses;
  detail::forEachLine(path, [&](const std::string& line, std::size_t line_no) {
    Fields fields(line);
    double v[12];
    std::size_t k = 0;
    std::string_view field;
    while (fields.next(field)) {
      if (k == 12)
        fail(path, line_no, "more than 12 numbers (a row-major 3x4 [R|t])");
      if (!parseNumber(field, v[k]) || !std::isfinite(v[k]))
        fail(path,
             line_no,
             "column " + std::to_string(k + 1) + " is not a finite number: " + inQuotes(field));
      ++k;
    }
    if (k != 12)
      fail(path,
           line_no,
           "expected 12 numbers (a row-major 3x4 [R|t]), got " + std::to_string(k));
    Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
    for (std::size_t i = 0; i < 12; ++i)
      pose(static_cast<Eigen::Index>(i / 4), static_cast<Eigen::Index>(i % 4)) = v[i];
    poses.push_back(pose);
  });
  return poses;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr
loadScan(const std::string& path,
         double min_range,
         double max_range,
         std::vector<double>* point_times)
{
  if (point_times)
    point_times->clear();
  const Extension* ext = findExtension(path);
  if (!ext) {
    std::string supported;
    for (const Extension& e : kExtensions)
      supported += std::string(supported.empty() ? "" : " ") + e.name;
    throw std::invalid_argument(
        "pcl_parallel::io::loadScan: " + path + ": unsupported extension " +
        inQuotes(detail::lowerCaseExtension(path)) + " (supported: " + supported + ")");
  }
  requireRegularFile(path);
  return detail::guardAllocation(path, [&] {
    switch (ext->format) {
    case Format::Uos:
      return loadUosScan(path, min_range, max_range);
    case Format::Xyz:
      return loadXyzScan(path, min_range, max_range);
    case Format::Kitti:
      return loadKittiScan(path, min_range, max_range);
    case Format::Pcd:
      return loadPcdScan(path, min_range, max_range, point_times);
    case Format::Ply:
      return loadPlyScan(path, min_range, max_range, point_times);
    }
    fail(path, 0, "internal error: unhandled scan format"); // unreachable: the switch is total
  });
}

bool
isScanFile(const std::string& path)
{
  return findExtension(path) != nullptr;
}

std::string
scanFormatFromName(const std::string& name)
{
  std::string n = name;
  std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  if (n == "uos" || n == "3d")
    return "3d";
  if (n == "velodyne" || n == "kitti" || n == "bin")
    return "bin";
  if (n == "pcl")
    return "pcd";
  return isScanFile("x." + n) ? n : "";
}

} // namespace io
} // namespace pcl_parallel
