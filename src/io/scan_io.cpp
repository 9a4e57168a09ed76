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

/** The fields of a text line: separated by white space, by a comma, or by a comma with
 *  white space around it. Two commas in a row delimit an empty field (which is not a
 *  number), so a missing CSV value is reported rather than the next column read in its
 *  place. */
class Fields {
public:
  explicit Fields(const std::string& line)
      : pos_(line.data())
      , end_(line.data() + line.size())
  {}

  /** The next field; false at the end of the line. */
  bool
  next(std::string_view& field)
  {
    skipSpace();
    if (!first_ && pos_ != end_ && *pos_ == ',') {
      ++pos_;
      skipSpace();
    }
    first_ = false;
    if (pos_ == end_)
      return false;
    const char* begin = pos_;
    while (pos_ != end_ && *pos_ != ',' && !isSpace(*pos_))
      ++pos_;
    field = std::string_view(begin, static_cast<std::size_t>(pos_ - begin));
    return true;
  }

private:
  static bool
  isSpace(char c)
  {
    return c != '\0' && std::strchr(detail::kSpace, c) != nullptr;
  }
  void
  skipSpace()
  {
    while (pos_ != end_ && isSpace(*pos_))
      ++pos_;
  }

  const char* pos_;
  const char* end_;
  bool first_ = true;
};

/** Parses a whole field as a double with std::from_chars: independent of the locale
 *  (unlike strtod and iostreams under a global locale with a decimal comma), and it reads
 *  "nan" and "inf". A leading '+' is accepted as printf("%+f") writes it. A value out of
 *  double's range is not a number. */
bool
parseNumber(std::string_view field, double& value)
{
  const char* begin = field.data();
  const char* end = begin + field.size();
  if (begin != end && *begin == '+') {
    ++begin;
    if (begin != end && *begin == '-')
      return false;
  }
  const auto [ptr, ec] = std::from_chars(begin, end, value);
  return begin != end && ec == std::errc() && ptr == end;
}

std::string
inQuotes(std::string_view s)
{
  return "\"" + std::string(s) + "\"";
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

/** PCD and PLY through PCL. Its readers print and return < 0 on most errors but throw
 *  pcl::PCLException on some; both become our std::runtime_error. PCL 1.13's PCD reader
 *  dereferences the first field of a header that has none (an empty or non-PCD file:
 *  PCL issue #5854, fixed in 1.14), so the header is read first and such a file
 *  rejected. Read as a PCLPointCloud2 because pcl::fromPCLPointCloud2 only warns about a
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
      if (pcl::PCDReader().readHeader(path, blob) < 0)
        fail(path, 0, cannot + " (PCL printed the reason)");
      if (blob.fields.empty())
        fail(path, 0, cannot + ": no FIELDS in the header");
      rc = pcl::io::loadPCDFile(path, blob);
    }
    else
      rc = pcl::io::loadPLYFile(path, blob);
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
  pcl::PointCloud<pcl::PointXYZ> raw;
  pcl::fromPCLPointCloud2(blob, raw);
  detail::RangeFilteredCloud cloud(min_range, max_range);
  cloud.reserve(raw.size());
  for (const pcl::PointXYZ& p : raw)
    cloud.add(p.x, p.y, p.z);
  return cloud.finish();
}

} // namespace

pcl::PointCloud<pcl::PointXYZ>::Ptr
loadXyzScan(const std::string& path, double min_range, double max_range)
{
  detail::RangeFilteredCloud cloud(min_range, max_range);
  detail::forEachLine(path, [&](const std::string& line, std::size_t line_no) {
    if (line[line.find_first_not_of(detail::kSpace)] == '#')
      return;
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
    cloud.add(v[0], v[1], v[2]);
  });
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
  std::vector<unsigned char> bytes(static_cast<std::size_t>(size));
  if (size > 0 && !in.read(reinterpret_cast<char*>(bytes.data()), size))
    fail(path, 0, "read error");
  const std::size_t n = bytes.size() / kRecordBytes;
  detail::RangeFilteredCloud cloud(min_range, max_range);
  cloud.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char* record = bytes.data() + i * kRecordBytes;
    cloud.add(floatLittleEndian(record),
              floatLittleEndian(record + 4),
              floatLittleEndian(record + 8));
  }
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
}

bool
isScanFile(const std::string& path)
{
  return findExtension(path) != nullptr;
}

} // namespace io
} // namespace pcl_parallel
