/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "detail.h"

#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/uos.h>

#include <pcl/PCLPointCloud2.h>
#include <pcl/common/io.h>
#include <pcl/conversions.h>
#include <pcl/exceptions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>

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

/** KITTI stores float32 little-endian; assembling the bytes keeps the reader correct on a
 *  big-endian host too (compilers turn this into one load on little-endian ones). */
float
floatLittleEndian(const unsigned char* b)
{
  static_assert(sizeof(float) == 4 && std::numeric_limits<float>::is_iec559,
                "KITTI scans are IEEE 754 float32");
  const std::uint32_t u =
      static_cast<std::uint32_t>(b[0]) | static_cast<std::uint32_t>(b[1]) << 8 |
      static_cast<std::uint32_t>(b[2]) << 16 | static_cast<std::uint32_t>(b[3]) << 24;
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
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

std::string
lowerCaseExtension(const std::string& path)
{
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  return ext;
}

const Extension*
findExtension(const std::string& path)
{
  const std::string ext = lowerCaseExtension(path);
  for (const Extension& e : kExtensions)
    if (ext == e.name)
      return &e;
  return nullptr;
}

/** Bytes in the file, or fails. */
std::uintmax_t
fileSize(const std::string& path)
{
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec)
    fail(path, 0, "cannot determine the file size: " + ec.message());
  return size;
}

/** A PLY header's element counts against the file size, before PCL allocates for them:
 *  every element with properties takes at least one byte, so a count above the file size
 *  is a corrupt header (PCL would try to allocate it: std::bad_alloc or the OOM killer).
 *  An element without properties takes none, but PCL's parser still loops over its count
 *  (8e18 of them: a hang, found by the fuzz stage), so its count is bounded alike. */
void
checkPlyHeader(const std::string& path)
{
  const std::uintmax_t size = fileSize(path);
  std::ifstream in = detail::openOrThrow(path, std::ios::in | std::ios::binary);
  std::string line;
  double count = 0;
  auto checkElement = [&] {
    if (count > static_cast<double>(size)) {
      char claimed[32];
      std::snprintf(claimed, sizeof claimed, "%.0f", count);
      fail(path,
           0,
           std::string("PLY header claims ") + claimed + " elements, more than the file's " +
               std::to_string(size) + " bytes");
    }
  };
  for (std::size_t n = 0; std::getline(in, line) && n < 10000; ++n) {
    Fields fields(line);
    std::string_view word, name, value;
    if (!fields.next(word))
      continue;
    if (word == "end_header")
      break;
    if (word != "element")
      continue;
    checkElement();
    if (!fields.next(name) || !fields.next(value) || !parseNumber(value, count) ||
        !(count >= 0))
      fail(path, 0, "PLY header: malformed element line " + inQuotes(line));
  }
  checkElement();
}

/** A PCD header's point count against the file size (see checkPlyHeader), read by us
 *  because PCL's readHeader already allocates for it: ASCII takes at least one byte a
 *  point, binary the sum of SIZE x COUNT, binary_compressed at least 1/100 of that (LZF's
 *  back-references expand 3 bytes to at most 264, 88x). Malformed headers are left to
 *  PCL's reader, which rejects them. */
void
checkPcdHeader(const std::string& path)
{
  const std::uintmax_t size = fileSize(path);
  std::ifstream in = detail::openOrThrow(path, std::ios::in | std::ios::binary);
  std::string line;
  double width = 1, height = 1, points = -1, step = 0;
  std::vector<double> sizes, counts;
  std::string data;
  std::uintmax_t header_bytes = 0;
  for (std::size_t n = 0; n < 1000 && std::getline(in, line); ++n) {
    header_bytes += line.size() + 1;
    Fields fields(line);
    std::string_view key, value;
    if (!fields.next(key))
      continue;
    std::vector<double> values;
    while (fields.next(value)) {
      double v;
      if (key == "DATA")
        data = std::string(value);
      else if (parseNumber(value, v))
        values.push_back(v);
    }
    if (key == "WIDTH" && !values.empty())
      width = values[0];
    else if (key == "HEIGHT" && !values.empty())
      height = values[0];
    else if (key == "POINTS" && !values.empty())
      points = values[0];
    else if (key == "SIZE")
      sizes = values;
    else if (key == "COUNT")
      counts = values;
    else if (key == "DATA")
      break;
  }
  for (std::size_t i = 0; i < sizes.size(); ++i)
    step += sizes[i] * (i < counts.size() ? counts[i] : 1.0);
  const double claimed = std::max(points, width * height);
  const double body = size > header_bytes ? static_cast<double>(size - header_bytes) : 0.0;
  const double bytes = data == "ascii" ? claimed : claimed * std::max(step, 1.0);
  const double limit = data == "binary_compressed" ? 100.0 * body : body;
  if (bytes > limit) {
    char msg[160];
    std::snprintf(msg,
                  sizeof msg,
                  "PCD header claims %.0f points, more than the file's %ju bytes hold",
                  claimed,
                  size);
    fail(path, 0, msg);
  }
  if (data != "binary_compressed")
    return;
  // PCL allocates the uncompressed size stored in the body (found by the fuzz stage):
  // it must be the header's points x point size, and the compressed size must fit.
  unsigned char words[8];
  if (!in.read(reinterpret_cast<char*>(words), sizeof words))
    fail(path, 0, "binary_compressed PCD without its size words");
  auto u32 = [&](int at) {
    return static_cast<std::uint32_t>(words[at]) |
           static_cast<std::uint32_t>(words[at + 1]) << 8 |
           static_cast<std::uint32_t>(words[at + 2]) << 16 |
           static_cast<std::uint32_t>(words[at + 3]) << 24;
  };
  if (u32(0) > body || static_cast<double>(u32(4)) != bytes)
    fail(path,
         0,
         "binary_compressed sizes (" + std::to_string(u32(0)) + " compressed, " +
             std::to_string(u32(4)) + " uncompressed) disagree with the header");
}

/** PCD and PLY through PCL. Its readers print and return < 0 on most errors but throw
 *  pcl::PCLException on some; both become our std::runtime_error, as does an allocation
 *  failure. The header is read and checked first: PCL 1.13's PCD reader dereferences the
 *  first field of a header that has none (an empty or non-PCD file: PCL issue #5854, fixed
 *  in 1.14), and a point count beyond the file size is rejected before PCL allocates for
 *  it. Read as a PCLPointCloud2 because pcl::fromPCLPointCloud2 only warns about a
 *  missing or differently typed x, y or z field and leaves the coordinates at 0: every
 *  point would sit at the origin. */
pcl::PointCloud<pcl::PointXYZ>::Ptr
loadPclScan(const std::string& path, Format format, double min_range, double max_range)
{
  const std::string cannot =
      std::string("PCL cannot read it as ") + (format == Format::Pcd ? "PCD" : "PLY");
  pcl::PCLPointCloud2 blob;
  int rc = -1;
  try {
    if (format == Format::Pcd) {
      checkPcdHeader(path);
      if (pcl::PCDReader().readHeader(path, blob) < 0)
        fail(path, 0, cannot + " (PCL printed the reason)");
      if (blob.fields.empty())
        fail(path, 0, cannot + ": no FIELDS in the header");
      rc = pcl::io::loadPCDFile(path, blob);
    }
    else {
      checkPlyHeader(path);
      rc = pcl::io::loadPLYFile(path, blob);
    }
  }
  catch (const pcl::PCLException& e) {
    fail(path, 0, cannot + ": " + e.what());
  }
  if (rc < 0)
    fail(path, 0, cannot + " (PCL printed the reason)");
  for (const char* name : {"x", "y", "z"}) {
    const int i = pcl::getFieldIndex(blob, name);
    if (i < 0)
      fail(path, 0, std::string("no field \"") + name + "\"");
    const pcl::PCLPointField& f = blob.fields[static_cast<std::size_t>(i)];
    if (f.datatype != pcl::PCLPointField::FLOAT32 || f.count != 1)
      fail(path, 0, std::string("field \"") + name + "\" is not a single float32");
  }
  // pcl::fromPCLPointCloud2 trusts the blob's layout; a reader that parsed a damaged file
  // can return fewer bytes than width x height points, and for no points it takes
  // &cloud[0] of an empty vector (UB; both found by the fuzz stage).
  const std::size_t points = static_cast<std::size_t>(blob.width) * blob.height;
  detail::RangeFilteredCloud cloud(path, min_range, max_range);
  if (points == 0)
    return cloud.finish();
  for (const char* name : {"x", "y", "z"}) {
    const auto& f = blob.fields[static_cast<std::size_t>(pcl::getFieldIndex(blob, name))];
    if (std::size_t{f.offset} + 4 > blob.point_step)
      fail(path, 0, cannot + ": field offsets beyond the point size");
  }
  if (std::size_t{blob.point_step} * blob.width > blob.row_step ||
      std::size_t{blob.row_step} * blob.height > blob.data.size())
    fail(path, 0, cannot + ": fewer data bytes than the header's points");
  pcl::PointCloud<pcl::PointXYZ> raw;
  pcl::fromPCLPointCloud2(blob, raw);
  cloud.reserve(raw.size());
  for (std::size_t i = 0; i < raw.size(); ++i)
    cloud.add(raw[i].x, raw[i].y, raw[i].z, i + 1);
  return cloud.finish();
}

/** KITTI plausibility (the format has no header or magic number, so only the values can
 *  tell): a Velodyne HDL-64E reports up to 120 m (KITTI, Geiger et al. 2013), so a
 *  coordinate or reflectance beyond kKittiMaxValue or infinite is not a KITTI scan, and
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
      v[a] = floatLittleEndian(record + 4 * a);
      if (std::isinf(v[a]) || std::abs(v[a]) > kKittiMaxValue)
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
loadScan(const std::string& path, double min_range, double max_range)
{
  const Extension* ext = findExtension(path);
  if (!ext) {
    std::string supported;
    for (const Extension& e : kExtensions)
      supported += std::string(supported.empty() ? "" : " ") + e.name;
    throw std::invalid_argument(
        "pcl_parallel::io::loadScan: " + path + ": unsupported extension " +
        inQuotes(lowerCaseExtension(path)) + " (supported: " + supported + ")");
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
    case Format::Ply:
      return loadPclScan(path, ext->format, min_range, max_range);
    }
    fail(path, 0, "internal error: unhandled scan format"); // unreachable: the switch is total
  });
}

bool
isScanFile(const std::string& path)
{
  return findExtension(path) != nullptr;
}

} // namespace io
} // namespace pcl_parallel
