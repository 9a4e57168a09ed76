/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Private to src/io: what every scan reader shares, so that the error messages and the
 * range filter are the same whichever format a scan comes in.
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace pcl_parallel {
namespace io {
namespace detail {

/** Throws std::runtime_error "pcl_parallel::io: path:line: what" (no ":line" when line is
 *  0, for errors that concern the whole file), so a user can go straight to the bad line. */
[[noreturn]] inline void
fail(const std::string& path, std::size_t line, const std::string& what)
{
  std::ostringstream msg;
  msg << "pcl_parallel::io: " << path;
  if (line > 0)
    msg << ":" << line;
  msg << ": " << what;
  throw std::runtime_error(msg.str());
}

inline std::ifstream
openOrThrow(const std::string& path, std::ios::openmode mode = std::ios::in)
{
  std::ifstream in(path, mode);
  if (!in)
    fail(path, 0, "cannot open file for reading");
  return in;
}

/** White space in the text formats (a '\r' is what is left of a Windows line end). */
constexpr const char* kSpace = " \t\r\v\f";

/** Calls f(line, line_no) for every line of a text file that holds more than white space,
 *  with the line number as an editor shows it (from 1, blank lines counted), so a reader's
 *  errors point at the right line. Throws when the file cannot be opened or read. */
template <typename F>
void
forEachLine(const std::string& path, F&& f)
{
  std::ifstream in = openOrThrow(path);
  std::string line;
  std::size_t line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find_first_not_of(kSpace) != std::string::npos)
      f(line, line_no);
  }
  if (in.bad())
    fail(path, line_no, "read error");
}

/** Appends scan points that pass the one range filter of every reader: finite coordinates
 *  and a range sqrt(x²+y²+z²) from the scanner origin within [min_range, max_range].
 *  The range is computed in double before the point is narrowed to float, so a reader of
 *  double text and a reader of float binaries cut at the same place. finish() sets the
 *  header fields of an unorganised, dense cloud. */
class RangeFilteredCloud {
public:
  RangeFilteredCloud(double min_range, double max_range)
      : cloud_(new pcl::PointCloud<pcl::PointXYZ>)
      , min_range_(min_range)
      , max_range_(max_range)
  {}

  void
  reserve(std::size_t n)
  {
    cloud_->reserve(n);
  }

  void
  add(double x, double y, double z)
  {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      return;
    const double r = std::sqrt(x * x + y * y + z * z);
    if (r < min_range_ || r > max_range_)
      return;
    cloud_->push_back(
        pcl::PointXYZ(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)));
  }

  pcl::PointCloud<pcl::PointXYZ>::Ptr
  finish()
  {
    cloud_->width = static_cast<std::uint32_t>(cloud_->size());
    cloud_->height = 1;
    cloud_->is_dense = true;
    return cloud_;
  }

private:
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud_;
  double min_range_, max_range_;
};

} // namespace detail
} // namespace io
} // namespace pcl_parallel
