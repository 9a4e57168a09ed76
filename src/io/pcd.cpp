/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * PCD scans read by us, not by pcl::PCDReader: PCL 1.13's reader places fields by the
 * header's SIZE values but writes them by TYPE, indexes SIZE by a later FIELDS line, and
 * leaves a point at the origin when a line has too few values; on damaged headers it
 * wrote past its buffers (found by the fuzz stage; PCL is not instrumented, so the heap
 * damage surfaced as a bad free much later). Only x, y and z are needed, and the format is
 * small enough to check every byte of it here (docs/design.md, "Scan readers").
 */
#include "detail.h"

#include <pcl_parallel/io/atomic_write.h>
#include <pcl_parallel/io/scan_io.h>

#include <pcl/io/lzf.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

namespace pcl_parallel {
namespace io {

namespace {

using detail::fail;
using detail::Fields;
using detail::parseNumber;
using detail::readLine;

/** One FIELDS entry with its SIZE, TYPE and COUNT. */
struct PcdField {
  std::string name;
  detail::BinaryType type; ///< SIZE and TYPE
  std::size_t count = 1;   ///< values
  std::size_t offset = 0;
};

enum class PcdData { Ascii, Binary, Compressed };

struct PcdHeader {
  std::vector<PcdField> fields;
  std::size_t points = 0;
  std::size_t point_step = 0; ///< bytes of one point in the binary layouts
  PcdData data = PcdData::Ascii;
  std::array<std::size_t, 3> xyz{};    ///< the indices of x, y and z in fields
  std::size_t time = detail::kNoField; ///< the index of the per-point time field
  std::size_t lines = 0;               ///< header lines, DATA included
  std::streamoff body = 0;
};

// The keywords of PCD v0.7 (pointclouds.org, "The PCD file format"); COLUMNS is v0.5's
// name for FIELDS, which PCL still reads.
constexpr std::array<std::string_view, 10> kKeywords = {"VERSION",
                                                        "FIELDS",
                                                        "SIZE",
                                                        "TYPE",
                                                        "COUNT",
                                                        "WIDTH",
                                                        "HEIGHT",
                                                        "VIEWPOINT",
                                                        "POINTS",
                                                        "DATA"};

constexpr std::size_t kMaxCount = std::size_t{1} << 24; // values of one field in a point

/** A header count (WIDTH, HEIGHT, POINTS, SIZE, COUNT): a non-negative integer. */
bool
parseCount(std::string_view field, std::size_t& value)
{
  double v;
  if (!parseNumber(field, v) || !(v >= 0 && v < 1e15) ||
      v != static_cast<double>(static_cast<std::size_t>(v)))
    return false;
  value = static_cast<std::size_t>(v);
  return true;
}

/** What the header lines said beyond the fields: the counts, and which keywords came. */
struct PcdHeaderLines {
  std::vector<std::string_view> seen;
  std::size_t width = 0, height = 1, points = 0;
  bool has_width = false, has_points = false, has_data = false;
};

/** SIZE, TYPE or COUNT: one value per field, a type (I, U, F) or a count; `bad` fails. */
template <typename Bad>
void
readPerFieldValues(std::string_view keyword,
                   const std::vector<std::string_view>& values,
                   PcdHeader& h,
                   const Bad& bad)
{
  if (values.size() != h.fields.size())
    bad(std::to_string(values.size()) + " values for " + std::to_string(h.fields.size()) +
        " fields");
  for (std::size_t i = 0; i < values.size(); ++i) {
    PcdField& f = h.fields[i];
    if (keyword == "TYPE" && values[i].size() == 1)
      f.type.kind = values[i][0];
    else if (keyword == "TYPE" ||
             !parseCount(values[i], keyword == "SIZE" ? f.type.size : f.count))
      bad("value " + detail::quoted(values[i]) + " is not a " +
          (keyword == "TYPE" ? "type (I, U, F)" : "count"));
  }
}

/** One header line: keywords once each, FIELDS before SIZE, TYPE and COUNT, one value
 *  per field on each, one count on WIDTH, HEIGHT and POINTS, a known DATA layout. */
void
readPcdHeaderLine(const std::string& path,
                  const std::string& line,
                  std::size_t line_no,
                  PcdHeader& h,
                  PcdHeaderLines& s)
{
  Fields fields(line);
  std::string_view key, value;
  if (!fields.next(key) || key[0] == '#')
    return;
  const std::string_view keyword = key == "COLUMNS" ? "FIELDS" : key;
  if (std::find(kKeywords.begin(), kKeywords.end(), keyword) == kKeywords.end())
    fail(path, line_no, "PCD header: unknown line " + detail::quoted(line));
  if (std::find(s.seen.begin(), s.seen.end(), keyword) != s.seen.end())
    fail(path, line_no, "PCD header: a second " + std::string(keyword) + " line");
  const bool per_field = keyword == "SIZE" || keyword == "TYPE" || keyword == "COUNT";
  if (per_field && h.fields.empty())
    fail(path, line_no, "PCD header: " + std::string(keyword) + " before FIELDS");
  s.seen.push_back(*std::find(kKeywords.begin(), kKeywords.end(), keyword));
  std::vector<std::string_view> values;
  while (fields.next(value))
    values.push_back(value);
  const auto bad = [&](const std::string& what) {
    fail(path, line_no, "PCD header: " + what + " in " + detail::quoted(line));
  };
  if (keyword == "FIELDS") {
    if (values.empty())
      bad("no field names");
    for (std::string_view name : values)
      h.fields.push_back(PcdField{std::string(name), {}, 1, 0});
  }
  else if (per_field)
    readPerFieldValues(keyword, values, h, bad);
  else if (keyword == "WIDTH" || keyword == "HEIGHT" || keyword == "POINTS") {
    std::size_t& target = keyword == "WIDTH"    ? s.width
                          : keyword == "HEIGHT" ? s.height
                                                : s.points;
    if (values.size() != 1 || !parseCount(values[0], target))
      bad("expected one count");
    s.has_width |= keyword == "WIDTH";
    s.has_points |= keyword == "POINTS";
  }
  else if (keyword == "DATA") {
    const std::string_view d = values.empty() ? std::string_view() : values[0];
    if (values.size() != 1 || (d != "ascii" && d != "binary" && d != "binary_compressed"))
      bad("expected ascii, binary or binary_compressed");
    h.data = d == "ascii"    ? PcdData::Ascii
             : d == "binary" ? PcdData::Binary
                             : PcdData::Compressed;
    s.has_data = true;
  }
}

/** The fields' layout (offsets, the point's size) and x, y and z: present once each, as
 *  single floats. */
void
layOutPcdFields(const std::string& path, PcdHeader& h)
{
  for (PcdField& f : h.fields) {
    if (!f.type.valid() || f.count == 0 || f.count > kMaxCount)
      fail(path,
           0,
           "PCD header: field \"" + f.name + "\" has no valid SIZE/TYPE/COUNT (" +
               std::to_string(f.type.size) + " bytes, type '" + std::string(1, f.type.kind) +
               "', " + std::to_string(f.count) + " values)");
    f.offset = h.point_step;
    h.point_step += f.type.size * f.count;
  }
  for (std::size_t a = 0; a < 3; ++a) {
    const std::string name(1, static_cast<char>('x' + a));
    const auto is = [&](const PcdField& f) { return f.name == name; };
    const auto f = std::find_if(h.fields.begin(), h.fields.end(), is);
    if (f == h.fields.end())
      fail(path, 0, "no field \"" + name + "\"");
    if (std::count_if(h.fields.begin(), h.fields.end(), is) > 1)
      fail(path, 0, "PCD header: field \"" + name + "\" appears twice");
    if (f->type.kind != 'F' || f->count != 1)
      fail(path, 0, "field \"" + name + "\" is not a single float32 or float64");
    h.xyz[a] = static_cast<std::size_t>(f - h.fields.begin());
  }
  h.time = detail::timeField(h.fields, [](const PcdField& f) { return f.count == 1; });
}

/** Reads and checks the header (readPcdHeaderLine, layOutPcdFields) and a point count
 *  that agrees with WIDTH x HEIGHT. */
PcdHeader
readPcdHeader(const std::string& path, std::ifstream& in)
{
  PcdHeader h;
  PcdHeaderLines s;
  std::string line;
  while (!s.has_data && readLine(in, line, path, h.lines + 1))
    readPcdHeaderLine(path, line, ++h.lines, h, s);
  if (!s.has_data)
    fail(path, 0, "PCD header without a DATA line (not a PCD file, or a truncated one)");
  if (h.fields.empty())
    fail(path, 0, "PCD header without FIELDS");
  if (!s.has_width && !s.has_points)
    fail(path, 0, "PCD header without WIDTH or POINTS: the point count is unknown");
  if (!s.has_width)
    s.width = s.points / std::max<std::size_t>(s.height, 1); // PCD v0.5: POINTS alone
  if (s.height != 0 && s.width > SIZE_MAX / s.height)
    fail(path, 0, "PCD header: WIDTH x HEIGHT overflows");
  h.points = s.width * s.height;
  if (s.has_points && s.points != h.points)
    fail(path,
         0,
         "PCD header: POINTS " + std::to_string(s.points) + " but WIDTH x HEIGHT " +
             std::to_string(h.points));
  layOutPcdFields(path, h);
  if (in.eof()) { // DATA was the last line, without a line end: an empty body
    in.clear();
    in.seekg(0, std::ios::end);
  }
  h.body = in.tellg();
  return h;
}

void
readAscii(const std::string& path,
          std::ifstream& in,
          const PcdHeader& h,
          detail::RangeFilteredCloud& cloud)
{
  // The value index of each field in a line: COUNT values a field, padding ("_") included.
  std::vector<std::size_t> first(h.fields.size() + 1, 0);
  for (std::size_t i = 0; i < h.fields.size(); ++i)
    first[i + 1] = first[i] + h.fields[i].count;
  const std::size_t per_line = first.back();
  std::size_t line_no = h.lines, read = 0;
  std::string line;
  while (readLine(in, line, path, line_no + 1)) {
    ++line_no;
    Fields fields(line);
    std::string_view v;
    std::size_t k = 0;
    double p[3], time = 0.0;
    while (fields.next(v)) {
      for (std::size_t a = 0; a < 3; ++a)
        if (k == first[h.xyz[a]] && !parseNumber(v, p[a]))
          fail(path,
               line_no,
               std::string(1, static_cast<char>('x' + a)) +
                   " is not a number: " + detail::quoted(v));
      if (h.time != detail::kNoField && k == first[h.time] && !parseNumber(v, time))
        fail(path, line_no, h.fields[h.time].name + " is not a number: " + detail::quoted(v));
      ++k;
    }
    if (k == 0)
      continue;
    if (k != per_line)
      fail(path,
           line_no,
           std::to_string(k) + " values where the header's fields take " +
               std::to_string(per_line));
    if (++read > h.points)
      fail(path, line_no, "more point lines than the header's " + std::to_string(h.points));
    cloud.add(p[0], p[1], p[2], line_no, time);
  }
  if (in.bad())
    fail(path, line_no, "read error");
  if (read < h.points)
    fail(path,
         0,
         "truncated: " + std::to_string(read) + " of the header's " + std::to_string(h.points) +
             " point lines");
}

std::uint32_t
uint32LittleEndian(const unsigned char* b)
{
  return static_cast<std::uint32_t>(detail::binaryValue(b, {'U', 4}));
}

/** binary_compressed (PCL's writer): the compressed and uncompressed sizes as two uint32,
 *  then LZF of the points stored field by field (all x, then all y, ...). Returns the
 *  decompressed bytes; the sizes must agree with the header (checked against the file
 *  size by the caller) before anything is allocated. */
std::vector<unsigned char>
decompress(const std::string& path, const std::vector<unsigned char>& body, const PcdHeader& h)
{
  if (body.size() < 8)
    fail(path, 0, "binary_compressed PCD without its size words");
  const std::uint32_t packed = uint32LittleEndian(body.data());
  const std::uint32_t unpacked = uint32LittleEndian(body.data() + 4);
  const double expected = static_cast<double>(h.points) * static_cast<double>(h.point_step);
  if (packed > body.size() - 8 || static_cast<double>(unpacked) != expected)
    fail(path,
         0,
         "binary_compressed sizes (" + std::to_string(packed) + " compressed, " +
             std::to_string(unpacked) + " uncompressed) disagree with the header's " +
             std::to_string(h.points) + " points of " + std::to_string(h.point_step) +
             " bytes");
  std::vector<unsigned char> out(unpacked);
  if (unpacked > 0 &&
      pcl::lzfDecompress(body.data() + 8, packed, out.data(), unpacked) != unpacked)
    fail(path, 0, "binary_compressed data does not decompress to the header's size");
  return out;
}

void
readBinary(const std::string& path,
           std::ifstream& in,
           const PcdHeader& h,
           detail::RangeFilteredCloud& cloud)
{
  in.seekg(h.body);
  const std::vector<unsigned char> body = detail::readRest(path, in);
  const bool compressed = h.data == PcdData::Compressed;
  // LZF's back-references expand 3 bytes to at most 264 (88x): a larger claim is damage.
  const double holds = static_cast<double>(body.size()) * (compressed ? 100.0 : 1.0);
  if (static_cast<double>(h.points) * static_cast<double>(h.point_step) > holds)
    fail(path,
         0,
         "the header's " + std::to_string(h.points) + " points of " +
             std::to_string(h.point_step) + " bytes are more than the file's " +
             std::to_string(body.size()) + " data bytes hold (truncated, or a damaged header)");
  const std::vector<unsigned char> unpacked =
      compressed ? decompress(path, body, h) : std::vector<unsigned char>();
  const unsigned char* data = compressed ? unpacked.data() : body.data();
  // Point i's field f: interleaved at i * point_step + offset, or, decompressed, in f's
  // block at points * offset + i * size.
  const auto value = [&](std::size_t field, std::size_t i) {
    const PcdField& f = h.fields[field];
    const std::size_t at =
        compressed ? h.points * f.offset + i * f.type.size : i * h.point_step + f.offset;
    return detail::binaryValue(data + at, f.type); // PCL writes the host order: little
  };
  const bool timed = h.time != detail::kNoField;
  cloud.reserve(h.points);
  for (std::size_t i = 0; i < h.points; ++i)
    cloud.add(value(h.xyz[0], i),
              value(h.xyz[1], i),
              value(h.xyz[2], i),
              i + 1,
              timed ? value(h.time, i) : 0.0);
}

} // namespace

pcl::PointCloud<pcl::PointXYZ>::Ptr
loadPcdScan(const std::string& path,
            double min_range,
            double max_range,
            std::vector<double>* point_times)
{
  std::ifstream in = detail::openOrThrow(path, std::ios::in | std::ios::binary);
  const PcdHeader h = readPcdHeader(path, in);
  detail::RangeFilteredCloud cloud(path, min_range, max_range);
  cloud.keepTimes(point_times, h.time != detail::kNoField);
  if (h.data == PcdData::Ascii)
    readAscii(path, in, h, cloud);
  else
    readBinary(path, in, h, cloud);
  return cloud.finish();
}

namespace detail {

void
writeXyzFile(const std::string& path,
             const std::string& header,
             const pcl::PointCloud<pcl::PointXYZ>& cloud)
{
  writeStreamAtomically(path, [&](std::ostream& out) {
    out << header;
    std::vector<float> xyz;
    constexpr std::size_t kChunk = 3 << 16;
    xyz.reserve(std::min(3 * cloud.size(), kChunk));
    for (std::size_t i = 0; i < cloud.size(); ++i) {
      xyz.insert(xyz.end(), {cloud[i].x, cloud[i].y, cloud[i].z});
      if (xyz.size() >= kChunk || i + 1 == cloud.size()) {
        out.write(reinterpret_cast<const char*>(xyz.data()),
                  static_cast<std::streamsize>(xyz.size() * sizeof(float)));
        xyz.clear();
      }
    }
  });
}

} // namespace detail

// PCD v0.7 (pointclouds.org, "The PCD file format"), the header as PCL writes it.
void
writePcdScan(const std::string& path, const pcl::PointCloud<pcl::PointXYZ>& cloud)
{
  std::ostringstream h;
  h << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z\n"
       "SIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH "
    << cloud.size() << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << cloud.size()
    << "\nDATA binary\n";
  detail::writeXyzFile(path, h.str(), cloud);
}

} // namespace io
} // namespace pcl_parallel
