/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "detail.h"

#include <pcl_parallel/io/carmen.h>

#include <boost/iostreams/filter/bzip2.hpp>
#include <boost/iostreams/filtering_stream.hpp>

#include <algorithm>
#include <cmath>
#include <ios>
#include <string_view>

namespace pcl_parallel {
namespace io {

double
carmenGuessFov(std::size_t beams)
{
  constexpr double kDeg = M_PI / 180.0;
  switch (beams) { // readlog.c: "last beam ignored" for the even counts
  case 180:
    return 179.0 * kDeg;
  case 360:
    return 179.5 * kDeg;
  case 400:
    return 99.75 * kDeg;
  case 401:
    return 100.0 * kDeg;
  default: // 181, 361 and anything else: 180 degrees
    return M_PI;
  }
}

double
carmenGuessAngleIncrement(std::size_t beams)
{
  if (beams == 180 || beams == 181)
    return M_PI / 180.0;
  if (beams == 360 || beams == 361)
    return M_PI / 360.0;
  if (beams == 400 || beams == 401)
    return M_PI / 720.0;
  return beams < 2 ? carmenGuessFov(beams) // no second beam: any increment is right
                   : carmenGuessFov(beams) / static_cast<double>(beams - 1);
}

Eigen::Matrix4d
planarPose(double x, double y, double theta)
{
  Eigen::Matrix4d pose = Eigen::Matrix4d::Identity();
  const double c = std::cos(theta), s = std::sin(theta);
  pose(0, 0) = c;
  pose(0, 1) = -s;
  pose(1, 0) = s;
  pose(1, 1) = c;
  pose(0, 3) = x;
  pose(1, 3) = y;
  return pose;
}

namespace {

using detail::fail;

/** A CARMEN message name (ipc's message names: capitals, digits, '_'), so that a line of
 *  garbage is an error rather than a message skipped. */
bool
isMessageName(std::string_view name)
{
  if (name.empty() || !(name[0] >= 'A' && name[0] <= 'Z'))
    return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
  });
}

/** One line's fields, with its file and line for the errors. */
class Line {
public:
  Line(const std::string& path, std::size_t line_no, std::vector<std::string_view>& fields)
      : path_(path)
      , line_no_(line_no)
      , fields_(fields)
  {}

  std::size_t
  size() const
  {
    return fields_.size();
  }

  [[noreturn]] void
  fail(const std::string& what) const
  {
    detail::fail(path_, line_no_, what);
  }

  /** Field k as a number (a range: NaN and inf pass, and are dropped as no-returns). */
  double
  number(std::size_t k, const char* what) const
  {
    double v;
    if (!detail::parseNumber(fields_[k], v))
      fail(std::string(what) + " (field " + std::to_string(k + 1) +
           ") is not a number: " + detail::quoted(fields_[k]));
    return v;
  }

  /** Field k as a finite number: poses, times, velocities (the pose files' rule). */
  double
  finite(std::size_t k, const char* what) const
  {
    const double v = number(k, what);
    if (!std::isfinite(v))
      fail(std::string(what) + " (field " + std::to_string(k + 1) + ") is not finite");
    return v;
  }

  /** Field k as a count that still fits on a 64 KiB line. */
  std::size_t
  count(std::size_t k, const char* what) const
  {
    const double v = number(k, what);
    if (!(v >= 0.0 && v <= static_cast<double>(detail::kMaxLineLength) && v == std::floor(v)))
      fail(std::string(what) + " (field " + std::to_string(k + 1) +
           ") is no count: " + detail::quoted(fields_[k]));
    return static_cast<std::size_t>(v);
  }

  /** Fails unless the line has `expected` fields. */
  void
  requireFields(std::size_t expected, const char* layout) const
  {
    if (fields_.size() != expected)
      fail(std::string(detail::quoted(fields_[0])) + " needs " + std::to_string(expected) +
           " fields (" + layout + "), got " + std::to_string(fields_.size()));
  }

  std::string_view
  field(std::size_t k) const
  {
    return fields_[k];
  }

  std::size_t
  lineNumber() const
  {
    return line_no_;
  }

private:
  const std::string& path_;
  std::size_t line_no_;
  std::vector<std::string_view>& fields_;
};

/** The laser on the robot, robot⁻¹ · laser, as CARMEN's robot module composes the laser
 *  pose from the odometry and robot_frontlaser_offset. */
Eigen::Matrix4d
offsetOf(const Eigen::Matrix4d& robot, const Eigen::Matrix4d& laser)
{
  Eigen::Matrix4d offset = Eigen::Matrix4d::Identity();
  offset.topLeftCorner<3, 3>() =
      robot.topLeftCorner<3, 3>().transpose() * laser.topLeftCorner<3, 3>();
  offset.topRightCorner<3, 1>() = robot.topLeftCorner<3, 3>().transpose() *
                                  (laser.topRightCorner<3, 1>() - robot.topRightCorner<3, 1>());
  return offset;
}

/** The reader's state: what PARAM lines said so far, the beam directions of the last
 *  geometry (every scan of a log usually has the same), the log being filled. */
class CarmenReader {
public:
  CarmenReader(const std::string& path, const CarmenReadOptions& options)
      : path_(path)
      , options_(options)
  {}

  void
  read(const std::string& text, std::size_t line_no);

  CarmenLog
  finish(std::size_t lines)
  {
    if (log_.scans.empty() && log_.odometry.empty() && log_.params.empty() &&
        log_.skipped.empty())
      fail(path_, 0, "holds no CARMEN message (an empty or comment-only log)");
    log_.lines = lines;
    return std::move(log_);
  }

private:
  void
  readFLaser(const Line& line);
  void
  readRobotLaser1(const Line& line);
  void
  readOdometry(const Line& line);
  void
  readParam(const Line& line);
  /** The readings fields [first, first + n) as points, and the time stamps of the end. */
  void
  addScan(const Line& line, CarmenScan& scan, std::size_t first);

  const std::string& path_;
  CarmenReadOptions options_;
  double front_resolution_ = 0.0; ///< PARAM laser_front_laser_resolution (rad), 0: none
  double front_max_ = 0.0;        ///< PARAM robot_front_laser_max (m), 0: none
  std::vector<std::string_view> fields_;
  std::vector<double> cos_, sin_; ///< the beam directions of (start_, step_)
  double start_ = 0.0, step_ = 0.0;
  CarmenLog log_;
};

void
CarmenReader::read(const std::string& text, std::size_t line_no)
{
  const std::size_t first = text.find_first_not_of(detail::kSpace);
  if (text[first] == '#') // a comment
    return;
  fields_.clear();
  detail::Fields split(text);
  for (std::string_view f; split.next(f);)
    fields_.push_back(f);
  const Line line(path_, line_no, fields_);
  const std::string_view name = fields_[0];
  if (!isMessageName(name))
    line.fail("not a CARMEN message (a name of capitals, then its fields): " +
              detail::quoted(text));
  if (name == "FLASER")
    readFLaser(line);
  else if (name == "ROBOTLASER1")
    readRobotLaser1(line);
  else if (name == "ODOM")
    readOdometry(line);
  else if (name == "PARAM")
    readParam(line);
  else
    ++log_.skipped[std::string(name)];
}

void
CarmenReader::readFLaser(const Line& line)
{
  if (line.size() < 2)
    line.requireFields(2, "FLASER num_readings ...");
  const std::size_t n = line.count(1, "num_readings");
  line.requireFields(n + 11,
                     "FLASER num_readings r_0 ... r_n-1 x y theta odom_x odom_y odom_theta "
                     "ipc_timestamp ipc_hostname logger_timestamp");
  CarmenScan scan;
  scan.message = CarmenLaserMessage::FLaser;
  scan.start_angle = -M_PI / 2.0; // readlog.c
  scan.angular_resolution =
      front_resolution_ > 0.0 ? front_resolution_ : carmenGuessAngleIncrement(n);
  scan.max_range =
      front_max_ > 0.0 ? std::min(options_.max_range, front_max_) : options_.max_range;
  const std::size_t p = 2 + n;
  scan.laser_pose =
      planarPose(line.finite(p, "x"), line.finite(p + 1, "y"), line.finite(p + 2, "theta"));
  scan.robot_pose = planarPose(line.finite(p + 3, "odom_x"),
                               line.finite(p + 4, "odom_y"),
                               line.finite(p + 5, "odom_theta"));
  addScan(line, scan, 2);
}

void
CarmenReader::readRobotLaser1(const Line& line)
{
  constexpr const char* kLayout =
      "ROBOTLASER1 laser_type start_angle field_of_view angular_resolution maximum_range "
      "accuracy remission_mode num_readings r_0 ... num_remissions rem_0 ... laser_x laser_y "
      "laser_theta robot_x robot_y robot_theta tv rv forward_safety_dist side_safety_dist "
      "turn_axis ipc_timestamp ipc_hostname logger_timestamp";
  if (line.size() < 10)
    line.requireFields(10, kLayout);
  const std::size_t n = line.count(8, "num_readings");
  if (line.size() < n + 10)
    line.requireFields(n + 10, kLayout);
  const std::size_t m = line.count(9 + n, "num_remissions");
  line.requireFields(n + m + 24, kLayout);
  CarmenScan scan;
  scan.message = CarmenLaserMessage::RobotLaser1;
  scan.start_angle = line.finite(2, "start_angle");
  scan.angular_resolution = line.finite(4, "angular_resolution");
  const double line_max = line.finite(5, "maximum_range");
  scan.max_range = line_max > 0.0 ? std::min(options_.max_range, line_max) : options_.max_range;
  const std::size_t p = 10 + n + m;
  scan.laser_pose = planarPose(line.finite(p, "laser_x"),
                               line.finite(p + 1, "laser_y"),
                               line.finite(p + 2, "laser_theta"));
  scan.robot_pose = planarPose(line.finite(p + 3, "robot_x"),
                               line.finite(p + 4, "robot_y"),
                               line.finite(p + 5, "robot_theta"));
  for (std::size_t k = p + 6; k < p + 11; ++k)
    line.finite(k, "tv, rv, forward_safety_dist, side_safety_dist or turn_axis");
  addScan(line, scan, 9);
}

void
CarmenReader::addScan(const Line& line, CarmenScan& scan, std::size_t first)
{
  const std::size_t n = line.count(first - 1, "num_readings");
  scan.beams = n;
  scan.line = line.lineNumber();
  scan.timestamp = line.finite(line.size() - 3, "ipc_timestamp");
  scan.logger_timestamp = line.finite(line.size() - 1, "logger_timestamp");
  scan.laser_offset = offsetOf(scan.robot_pose, scan.laser_pose);
  if (cos_.size() != n || start_ != scan.start_angle || step_ != scan.angular_resolution) {
    cos_.resize(n);
    sin_.resize(n);
    for (std::size_t i = 0; i < n; ++i) { // beam i at start + i·res (readlog.c)
      const double a = scan.start_angle + static_cast<double>(i) * scan.angular_resolution;
      cos_[i] = std::cos(a);
      sin_[i] = std::sin(a);
    }
    start_ = scan.start_angle;
    step_ = scan.angular_resolution;
  }
  scan.cloud.reset(new pcl::PointCloud<pcl::PointXYZ>);
  scan.cloud->reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double r = line.number(first + i, "a range");
    // Not finite, no echo (<= 0), too near, or "no return" (saturation at the maximum).
    if (!std::isfinite(r) || r <= 0.0 || r < options_.min_range || r >= scan.max_range)
      continue;
    scan.cloud->push_back(
        pcl::PointXYZ(static_cast<float>(r * cos_[i]), static_cast<float>(r * sin_[i]), 0.0f));
  }
  scan.cloud->width = static_cast<std::uint32_t>(scan.cloud->size());
  scan.cloud->height = 1;
  scan.cloud->is_dense = true;
  log_.scans.push_back(std::move(scan));
}

void
CarmenReader::readOdometry(const Line& line)
{
  line.requireFields(10,
                     "ODOM x y theta tv rv accel ipc_timestamp ipc_hostname "
                     "logger_timestamp");
  CarmenOdometry odom;
  odom.line = line.lineNumber();
  odom.pose = planarPose(line.finite(1, "x"), line.finite(2, "y"), line.finite(3, "theta"));
  odom.tv = line.finite(4, "tv");
  odom.rv = line.finite(5, "rv");
  odom.accel = line.finite(6, "accel");
  odom.timestamp = line.finite(7, "ipc_timestamp");
  odom.logger_timestamp = line.finite(9, "logger_timestamp");
  log_.odometry.push_back(odom);
}

void
CarmenReader::readParam(const Line& line)
{
  // "PARAM name value ipc_timestamp ipc_hostname logger_timestamp"; intel's two PARAM
  // lines lack the ipc_timestamp ("PARAM robot_frontlaser_offset 0.0 nohost 0").
  if (line.size() < 5)
    line.requireFields(6, "PARAM name value ipc_timestamp ipc_hostname logger_timestamp");
  CarmenParam param;
  param.line = line.lineNumber();
  param.name = std::string(line.field(1));
  const std::size_t end = line.size() == 5 ? 3 : line.size() - 3;
  for (std::size_t k = 2; k < end; ++k) // a value may hold spaces
    param.value += (k > 2 ? " " : "") + std::string(line.field(k));
  if (line.size() > 5)
    line.finite(line.size() - 3, "ipc_timestamp");
  line.finite(line.size() - 1, "logger_timestamp");
  // The front laser's geometry, for the FLASER lines after it (CARMEN's laser module).
  if (param.name == "laser_front_laser_resolution" || param.name == "robot_front_laser_max") {
    const double v = end == 3 ? line.finite(2, "the value") : -1.0;
    if (!(v > 0.0))
      line.fail(param.name + " is no positive number: " + detail::quoted(param.value));
    if (param.name == "laser_front_laser_resolution")
      front_resolution_ = v * M_PI / 180.0; // degrees in the log
    else
      front_max_ = v;
  }
  log_.params.push_back(std::move(param));
}

/** What a bzip2 error code (bzlib.h's BZ_*) means for the file. */
std::string
bzip2Problem(int code)
{
  namespace bz = boost::iostreams::bzip2; // its codes are link-time constants: no switch
  if (code == bz::data_error_magic)
    return "not bzip2 data";
  if (code == bz::data_error)
    return "corrupt bzip2 data";
  if (code == bz::unexpected_eof)
    return "the bzip2 stream ends early (a truncated file)";
  return "bzip2 error " + std::to_string(code);
}

/** A bzip2 stream's error (a corrupt or truncated .bz2) with the line it stopped at. */
template <typename F>
void
readingBzip2(const std::string& path, const std::size_t& line_no, F&& f)
{
  try {
    f();
  }
  catch (const boost::iostreams::bzip2_error& e) {
    fail(path, line_no + 1, "cannot decompress: " + bzip2Problem(e.error()));
  }
  catch (const std::ios_base::failure& e) {
    fail(path, line_no + 1, std::string("cannot decompress: ") + e.what());
  }
}

} // namespace

CarmenLog
loadCarmenLog(const std::string& path, const CarmenReadOptions& options)
{
  if (!(options.max_range > 0.0) || !(options.min_range >= 0.0))
    throw std::invalid_argument("pcl_parallel::io::loadCarmenLog: max_range must be > 0 and "
                                "min_range >= 0");
  CarmenReader reader(path, options);
  std::size_t lines = 0;
  const auto each = [&](const std::string& text, std::size_t line_no) {
    lines = line_no;
    reader.read(text, line_no);
  };
  std::ifstream file = detail::openOrThrow(path, std::ios::in | std::ios::binary);
  if (detail::lowerCaseExtension(path) == ".bz2") {
    boost::iostreams::filtering_istream in;
    in.push(boost::iostreams::bzip2_decompressor());
    in.push(file);
    in.exceptions(std::ios::badbit); // the decompressor's error, not a bare "read error"
    readingBzip2(path, lines, [&] { detail::forEachLine(in, path, each); });
  }
  else
    detail::forEachLine(file, path, each);
  return reader.finish(lines);
}

} // namespace io
} // namespace pcl_parallel
