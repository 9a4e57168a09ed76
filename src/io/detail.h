/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Private to src/io: what every scan reader shares, so that the error messages and the
 * range filter are the same whichever format a scan comes in.
 */
#pragma once

#include <pcl_parallel/io/scan_io.h>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <new>
#include <sstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

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

/** The extension of `path` with its dot, in ASCII lower case (".pcd"). */
inline std::string
lowerCaseExtension(const std::string& path)
{
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) {
    return static_cast<char>(std::tolower(c));
  });
  return ext;
}

/** White space in the text formats (a '\r' is what is left of a Windows line end). */
constexpr const char* kSpace = " \t\r\v\f";

/** A piece of a file for an error message: in quotes, at most 40 bytes (then "..." and the
 *  length), bytes outside printable ASCII as \xNN, so a binary file read as text gives a
 *  short, printable message instead of the whole "line". */
inline std::string
quoted(std::string_view s)
{
  constexpr std::size_t kMax = 40;
  std::string out = "\"";
  for (std::size_t i = 0; i < s.size() && i < kMax; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f && c != '"' && c != '\\')
      out += static_cast<char>(c);
    else {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    }
  }
  out += "\"";
  if (s.size() > kMax)
    out += "... (" + std::to_string(s.size()) + " bytes)";
  return out;
}

/** The one number parser of every text format: a whole field as a double with
 *  std::from_chars, independent of the C and C++ locales (unlike strtod and iostreams
 *  under a locale with a decimal comma); it reads "nan" and "inf". A leading '+' is
 *  accepted as printf("%+f") writes it. A value out of double's range is not a number. */
inline bool
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

/** The fields of a text line: separated by white space, by a comma, or by a comma with
 *  white space around it. Two commas in a row delimit an empty field (which is not a
 *  number), so a missing CSV value is reported rather than the next column read in its
 *  place. */
class Fields {
public:
  explicit Fields(std::string_view line)
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
    return c != '\0' && std::strchr(kSpace, c) != nullptr;
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

/** Reads up to n fields of a line as numbers; returns how many leading fields were numbers
 *  (stops at the first that is not, or at the end of the line). */
inline std::size_t
parseNumbers(std::string_view line, double* out, std::size_t n)
{
  Fields fields(line);
  std::string_view field;
  std::size_t k = 0;
  while (k < n && fields.next(field) && parseNumber(field, out[k]))
    ++k;
  return k;
}

/** A pose read as a whole 4x4 matrix (.frames) must be a rigid motion's: its last row
 *  0 0 0 1, up to 1e-9 (what printing and arithmetic of the writer may leave), then set
 *  exactly. False for any other last row. */
inline bool
homogeneousLastRow(Eigen::Matrix4d& pose)
{
  if (!((pose.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() <= 1e-9))
    return false;
  pose.row(3) << 0, 0, 0, 1;
  return true;
}

/** Runs f() and turns an allocation failure into our error naming the file: a header that
 *  claims more points than memory holds must not escape as a bare std::bad_alloc. */
template <typename F>
auto
guardAllocation(const std::string& path, F&& f) -> decltype(f())
{
  try {
    return f();
  }
  catch (const std::bad_alloc&) {
    fail(path, 0, "out of memory while reading it (a corrupt point count?)");
  }
  catch (const std::length_error&) {
    fail(path, 0, "point count too large to hold in memory (a corrupt header?)");
  }
}

/** A binary number as PCD and PLY describe one: kind 'I' (signed integer), 'U' (unsigned)
 *  or 'F' (IEEE 754), of 1, 2, 4 or 8 bytes (F: 4 or 8). */
struct BinaryType {
  char kind = 'F';
  std::size_t size = 4;

  bool
  valid() const
  {
    return ((kind == 'I' || kind == 'U') &&
            (size == 1 || size == 2 || size == 4 || size == 8)) ||
           (kind == 'F' && (size == 4 || size == 8));
  }
};

/** The value of a binary number in little- or big-endian byte order, assembled byte by
 *  byte so the readers are right on a host of either order. */
inline double
binaryValue(const unsigned char* bytes, BinaryType type, bool big_endian = false)
{
  static_assert(std::numeric_limits<float>::is_iec559 && std::numeric_limits<double>::is_iec559,
                "PCD, PLY and KITTI store IEEE 754 floats");
  std::uint64_t u = 0;
  for (std::size_t i = 0; i < type.size; ++i)
    u |= static_cast<std::uint64_t>(bytes[big_endian ? type.size - 1 - i : i]) << (8 * i);
  if (type.kind == 'F' && type.size == 4) {
    const auto v = static_cast<std::uint32_t>(u);
    float f;
    std::memcpy(&f, &v, sizeof f);
    return f;
  }
  if (type.kind == 'F') {
    double d;
    std::memcpy(&d, &u, sizeof d);
    return d;
  }
  if (type.kind == 'I' && type.size < 8) { // sign-extend
    const std::uint64_t sign = std::uint64_t{1} << (8 * type.size - 1);
    return static_cast<double>(static_cast<std::int64_t>((u ^ sign) - sign));
  }
  return type.kind == 'I' ? static_cast<double>(static_cast<std::int64_t>(u))
                          : static_cast<double>(u);
}

/** The rest of an open file, from its read position to its end (a binary body). */
inline std::vector<unsigned char>
readRest(const std::string& path, std::ifstream& in)
{
  const std::streamoff at = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff end = in.tellg();
  in.seekg(at);
  if (!in || at < 0 || end < at)
    fail(path, 0, "cannot determine the file size");
  std::vector<unsigned char> rest(static_cast<std::size_t>(end - at));
  if (!rest.empty() &&
      !in.read(reinterpret_cast<char*>(rest.data()), static_cast<std::streamsize>(rest.size())))
    fail(path, 0, "read error");
  return rest;
}

/** The longest line a text reader takes (bytes): longer is no point, pose or header
 *  line, and a file without line ends (binary data, a corrupt file) is refused after this
 *  much instead of read whole into memory. */
constexpr std::size_t kMaxLineLength = 65536;

/** Reads the next line of `in` into `line` (without its end): a line ends at "\n",
 *  "\r\n" or "\r" (Unix, Windows and classic Mac text); a last line without an end
 *  counts. False at the end of the input. Throws for a line over kMaxLineLength, naming
 *  `path` and the line `line_no`. Headers before binary data too: only a header ending in
 *  a lone "\r" loses its data's first byte if that is "\n" (PCL's reader, ending lines at
 *  "\n" alone, reads no such file either). */
inline bool
readLine(std::istream& in, std::string& line, const std::string& path, std::size_t line_no)
{
  line.clear();
  std::streambuf& buf = *in.rdbuf();
  constexpr int kEof = std::char_traits<char>::eof();
  for (int c = buf.sbumpc(); c != kEof; c = buf.sbumpc()) {
    if (c == '\n')
      return true;
    if (c == '\r') {
      if (buf.sgetc() == '\n')
        buf.sbumpc();
      return true;
    }
    if (line.size() == kMaxLineLength)
      fail(path, line_no, "line longer than " + std::to_string(kMaxLineLength) + " bytes");
    line.push_back(static_cast<char>(c));
  }
  in.setstate(std::ios::eofbit);
  return !line.empty();
}

/** Calls f(line, line_no) for every line of a text stream (readLine's line ends and limit)
 *  that holds more than white space, with the line number as an editor shows it (from 1,
 *  blank lines counted), so a reader's errors point at the right line. Reads in blocks
 *  (the scans' hot path: a character at a time through the stream is slower than
 *  std::getline). `path` names the source in errors; throws when it cannot be read. */
template <typename F>
void
forEachLine(std::istream& in, const std::string& path, F&& f)
{
  std::vector<char> block(1 << 16);
  std::string line;
  std::size_t line_no = 0;
  bool after_cr = false; // the previous block ended in "\r": a "\n" first belongs to it
  const auto isEnd = [](char c) { return c == '\n' || c == '\r'; };
  const auto emit = [&] {
    ++line_no;
    if (line.find_first_not_of(kSpace) != std::string::npos)
      f(line, line_no);
    line.clear();
  };
  while (in) {
    in.read(block.data(), static_cast<std::streamsize>(block.size()));
    const char* p = block.data();
    const char* const end = p + in.gcount();
    if (after_cr && p < end && *p == '\n')
      ++p;
    after_cr = false;
    while (p < end) {
      const char* e = std::find_if(p, end, isEnd);
      if (line.size() + static_cast<std::size_t>(e - p) > kMaxLineLength)
        fail(
            path, line_no + 1, "line longer than " + std::to_string(kMaxLineLength) + " bytes");
      line.append(p, e);
      if (e == end)
        break;
      p = e + 1;
      if (*e == '\r') { // "\r\n" is one end
        if (p < end && *p == '\n')
          ++p;
        else if (p == end)
          after_cr = true;
      }
      emit();
    }
  }
  if (in.bad())
    fail(path, line_no, "read error");
  if (!line.empty())
    emit();
}

/** forEachLine over the text file at `path`; throws when it cannot be opened. */
template <typename F>
void
forEachLine(const std::string& path, F&& f)
{
  std::ifstream in = openOrThrow(path);
  forEachLine(in, path, std::forward<F>(f));
}

constexpr std::size_t kNoField = static_cast<std::size_t>(-1);

/** The index in `fields` of the preferred per-point time field (kPointTimeFields) that
 *  `single` accepts (one number a point), or kNoField. */
template <typename Field, typename Single>
std::size_t
timeField(const std::vector<Field>& fields, Single single)
{
  for (const std::string_view name : kPointTimeFields)
    for (std::size_t i = 0; i < fields.size(); ++i)
      if (fields[i].name == name && single(fields[i]))
        return i;
  return kNoField;
}

/** A header, then x y z of every point as packed float32 in host order, atomically (the
 *  binary PCD and PLY writers; defined in pcd.cpp). */
void
writeXyzFile(const std::string& path,
             const std::string& header,
             const pcl::PointCloud<pcl::PointXYZ>& cloud);

/** Appends scan points that pass the one range filter of every reader: finite coordinates
 *  and a range sqrt(x²+y²+z²) from the scanner origin within [min_range, max_range].
 *  The range is computed in double before the point is narrowed to float, so a reader of
 *  double text and a reader of float binaries cut at the same place. A kept point with a
 *  coordinate beyond float's range (finite in double, inf as float) is an error naming the
 *  file and line, never an inf in a cloud marked dense. With keepTimes, each kept point's
 *  time is kept beside it and must be finite. finish() sets the header fields of an
 *  unorganised, dense cloud. */
class RangeFilteredCloud {
public:
  RangeFilteredCloud(const std::string& path, double min_range, double max_range)
      : cloud_(new pcl::PointCloud<pcl::PointXYZ>)
      , path_(path)
      , min_range_(min_range)
      , max_range_(max_range)
  {}

  void
  reserve(std::size_t n)
  {
    cloud_->reserve(n);
  }

  /** Clears `times` (if given) and, where the file has a time field, keeps there the time
   *  of each point add() keeps, in point order. */
  void
  keepTimes(std::vector<double>* times, bool file_has_times)
  {
    if (times)
      times->clear();
    times_ = file_has_times ? times : nullptr;
  }

  /** line: the line (text formats) or point (binary formats, from 1) for the error. */
  void
  add(double x, double y, double z, std::size_t line, double time = 0.0)
  {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      return;
    const double r = std::sqrt(x * x + y * y + z * z); // inf beyond 1e154: dropped or failed
    if (r == 0.0 || r < min_range_ || r > max_range_)  // at the origin: a no-return
      return;
    constexpr double kFloatMax = std::numeric_limits<float>::max();
    if (std::abs(x) > kFloatMax || std::abs(y) > kFloatMax || std::abs(z) > kFloatMax)
      fail(path_, line, "coordinate beyond float's range (3.4e38)");
    if (times_) {
      if (!std::isfinite(time))
        fail(path_, line, "the point's time is not a finite number");
      times_->push_back(time);
    }
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
  std::vector<double>* times_ = nullptr;
  std::string path_;
  double min_range_, max_range_;
};

} // namespace detail
} // namespace io
} // namespace pcl_parallel
