/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * PLY scans read by us, not by pcl::PLYReader: on damaged headers PCL 1.13's reader
 * asserts (an "obj_info" line after carriage returns aborts the process), loops over
 * element counts of 8e18, allocates what a header claims and returns blobs with fewer
 * bytes than points (all found by the fuzz stage). A scan needs the vertex element's x, y
 * and z; everything else is skipped by its declared layout.
 */
#include "detail.h"

#include <pcl_parallel/io/scan_io.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace pcl_parallel {
namespace io {

namespace {

using detail::BinaryType;
using detail::fail;
using detail::Fields;
using detail::parseNumber;

struct PlyProperty {
  std::string name;
  BinaryType type;
  bool list = false;
  BinaryType count_type; ///< of a list's length
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyFormat { Ascii, LittleEndian, BigEndian };

struct PlyHeader {
  PlyFormat format = PlyFormat::Ascii;
  std::vector<PlyElement> elements;
  std::size_t vertex = 0;              ///< index of the vertex element
  std::array<std::size_t, 3> xyz{};    ///< x, y, z among its properties
  std::size_t time = detail::kNoField; ///< the per-point time among them
  std::size_t lines = 0;
};

/** The PLY scalar types (Bourke's names and the sized ones of later writers). */
bool
plyType(std::string_view name, BinaryType& type)
{
  static const std::pair<std::string_view, BinaryType> kTypes[] = {{"char", {'I', 1}},
                                                                   {"int8", {'I', 1}},
                                                                   {"uchar", {'U', 1}},
                                                                   {"uint8", {'U', 1}},
                                                                   {"short", {'I', 2}},
                                                                   {"int16", {'I', 2}},
                                                                   {"ushort", {'U', 2}},
                                                                   {"uint16", {'U', 2}},
                                                                   {"int", {'I', 4}},
                                                                   {"int32", {'I', 4}},
                                                                   {"uint", {'U', 4}},
                                                                   {"uint32", {'U', 4}},
                                                                   {"float", {'F', 4}},
                                                                   {"float32", {'F', 4}},
                                                                   {"double", {'F', 8}},
                                                                   {"float64", {'F', 8}}};
  for (const auto& [n, t] : kTypes)
    if (n == name) {
      type = t;
      return true;
    }
  return false;
}

/** One header line after the magic: one format line, elements with counts the file size
 *  can hold (an element with properties takes at least a byte, and one without them is
 *  bounded alike), properties of known types. Returns true at end_header. */
bool
readPlyHeaderLine(const std::string& path,
                  const std::string& line,
                  std::size_t line_no,
                  std::uintmax_t file_size,
                  PlyHeader& h,
                  bool& has_format)
{
  Fields fields(line);
  std::string_view key;
  std::vector<std::string_view> v;
  if (!fields.next(key) || key == "comment" || key == "obj_info")
    return false;
  for (std::string_view value; fields.next(value);)
    v.push_back(value);
  const auto bad = [&](const std::string& what) {
    fail(path, line_no, "PLY header: " + what + " in " + detail::quoted(line));
  };
  if (key == "format") {
    if (has_format || v.size() != 2 || v[1] != "1.0")
      bad("expected one \"format <encoding> 1.0\"");
    if (v[0] == "ascii")
      h.format = PlyFormat::Ascii;
    else if (v[0] == "binary_little_endian")
      h.format = PlyFormat::LittleEndian;
    else if (v[0] == "binary_big_endian")
      h.format = PlyFormat::BigEndian;
    else
      bad("unknown encoding");
    has_format = true;
  }
  else if (key == "element") {
    double count = 0;
    if (v.size() != 2 || !parseNumber(v[1], count) || !(count >= 0) ||
        count != std::floor(count))
      bad("expected \"element <name> <count>\"");
    if (count > static_cast<double>(file_size))
      fail(path,
           line_no,
           "PLY header claims " + std::string(v[1]) + " elements, more than the file's " +
               std::to_string(file_size) + " bytes");
    h.elements.push_back(PlyElement{std::string(v[0]), static_cast<std::size_t>(count), {}});
  }
  else if (key == "property") {
    if (h.elements.empty())
      bad("a property before any element");
    PlyProperty p;
    const bool list = !v.empty() && v[0] == "list";
    if (list ? v.size() != 4 || !plyType(v[1], p.count_type) || p.count_type.kind == 'F' ||
                   !plyType(v[2], p.type)
             : v.size() != 2 || !plyType(v[0], p.type))
      bad("expected \"property <type> <name>\" or \"property list <type> <type> <name>\"");
    p.list = list;
    p.name = std::string(v.back());
    h.elements.back().properties.push_back(p);
  }
  else if (key == "end_header")
    return true;
  else
    bad("unknown keyword");
  return false;
}

/** The vertex element, with x, y and z as single floats, and its time property. */
void
findPlyVertex(const std::string& path, PlyHeader& h)
{
  const auto vertex = std::find_if(h.elements.begin(),
                                   h.elements.end(),
                                   [](const PlyElement& e) { return e.name == "vertex"; });
  if (vertex == h.elements.end())
    fail(path, 0, "PLY header without a vertex element");
  h.vertex = static_cast<std::size_t>(vertex - h.elements.begin());
  for (std::size_t a = 0; a < 3; ++a) {
    const std::string name(1, static_cast<char>('x' + a));
    const auto& props = vertex->properties;
    const auto p = std::find_if(
        props.begin(), props.end(), [&](const PlyProperty& q) { return q.name == name; });
    if (p == props.end())
      fail(path, 0, "no field \"" + name + "\"");
    if (p->list || p->type.kind != 'F')
      fail(path, 0, "field \"" + name + "\" is not a single float32 or float64");
    h.xyz[a] = static_cast<std::size_t>(p - props.begin());
  }
  h.time = detail::timeField(vertex->properties, [](const PlyProperty& p) { return !p.list; });
}

/** Reads and checks the header up to end_header: the magic line, then
 *  readPlyHeaderLine's checks, and a vertex element (findPlyVertex). */
PlyHeader
readPlyHeader(const std::string& path, std::ifstream& in, std::uintmax_t file_size)
{
  PlyHeader h;
  std::string line;
  bool has_format = false, ended = false;
  while (!ended && detail::readLine(in, line, path, h.lines + 1)) {
    const std::size_t line_no = ++h.lines;
    if (!line.empty() && line.back() == '\r')
      line.pop_back();
    if (line_no == 1 && line != "ply")
      fail(path,
           1,
           "not a PLY file: the first line is " + detail::quoted(line) + ", not \"ply\"");
    if (line_no > 1)
      ended = readPlyHeaderLine(path, line, line_no, file_size, h, has_format);
  }
  if (h.lines == 0)
    fail(path, 0, "not a PLY file: empty");
  if (!ended)
    fail(path, 0, "PLY header without end_header (not a PLY file, or a truncated one)");
  if (!has_format)
    fail(path, 0, "PLY header without a format line");
  findPlyVertex(path, h);
  return h;
}

/** ASCII body: one element a line, its properties in order (a list as its length, then
 *  the items). Elements after the vertices are not read. */
void
readAscii(const std::string& path,
          std::ifstream& in,
          const PlyHeader& h,
          detail::RangeFilteredCloud& cloud)
{
  std::size_t line_no = h.lines;
  std::string line;
  for (std::size_t e = 0; e <= h.vertex; ++e) {
    const PlyElement& element = h.elements[e];
    for (std::size_t i = 0; i < element.count; ++i) {
      do {
        if (!detail::readLine(in, line, path, line_no + 1))
          fail(path,
               line_no,
               "truncated: the file ends in element " + std::to_string(i + 1) + " of " +
                   std::to_string(element.count) + " \"" + element.name + "\"");
        ++line_no;
      } while (line.find_first_not_of(detail::kSpace) == std::string::npos);
      Fields fields(line);
      std::string_view token;
      double xyz[3] = {0, 0, 0}, time = 0.0;
      const auto next = [&](double& value) {
        if (!fields.next(token) || !parseNumber(token, value))
          fail(path,
               line_no,
               "expected " + element.name + " values as the header declares, got " +
                   detail::quoted(line));
      };
      for (std::size_t k = 0; k < element.properties.size(); ++k) {
        double value;
        next(value);
        if (element.properties[k].list) { // length, then the items, read and dropped
          if (!(value >= 0) || value != std::floor(value))
            fail(path, line_no, "list length " + detail::quoted(token) + " is not a count");
          double item;
          for (double left = value; left > 0; --left)
            next(item); // fails at the line's end: a long claim ends there
        }
        for (std::size_t a = 0; a < 3; ++a)
          if (e == h.vertex && k == h.xyz[a])
            xyz[a] = value;
        if (e == h.vertex && k == h.time)
          time = value;
      }
      if (fields.next(token))
        fail(path, line_no, "more values than the header declares: " + detail::quoted(line));
      if (e == h.vertex)
        cloud.add(xyz[0], xyz[1], xyz[2], line_no, time);
    }
  }
  if (in.bad())
    fail(path, line_no, "read error");
}

/** Binary body: the elements back to back, properties in order, a list as its length
 *  (count_type) then the items. Every read is checked against the bytes left. */
void
readBinary(const std::string& path,
           std::ifstream& in,
           const PlyHeader& h,
           detail::RangeFilteredCloud& cloud)
{
  const std::vector<unsigned char> body = detail::readRest(path, in);
  const bool big = h.format == PlyFormat::BigEndian;
  std::size_t at = 0;
  // The next `bytes` of element i, or a clear error where the data ends first.
  const auto take = [&](double bytes, const PlyElement& element, std::size_t i) {
    if (bytes > static_cast<double>(body.size() - at))
      fail(path,
           0,
           "truncated: the data ends in element " + std::to_string(i + 1) + " of " +
               std::to_string(element.count) + " \"" + element.name + "\"");
    const unsigned char* p = body.data() + at;
    at += static_cast<std::size_t>(bytes);
    return p;
  };
  for (std::size_t e = 0; e <= h.vertex; ++e) {
    const PlyElement& element = h.elements[e];
    if (e == h.vertex)
      cloud.reserve(std::min(element.count, body.size()));
    for (std::size_t i = 0; i < element.count; ++i) {
      double xyz[3] = {0, 0, 0}, time = 0.0;
      for (std::size_t k = 0; k < element.properties.size(); ++k) {
        const PlyProperty& p = element.properties[k];
        if (p.list) { // skipped: length, then the items
          const double n = detail::binaryValue(
              take(static_cast<double>(p.count_type.size), element, i), p.count_type, big);
          if (!(n >= 0))
            fail(path, 0, "negative list length in element \"" + element.name + "\"");
          take(n * static_cast<double>(p.type.size), element, i);
          continue;
        }
        const double value = detail::binaryValue(
            take(static_cast<double>(p.type.size), element, i), p.type, big);
        for (std::size_t a = 0; a < 3; ++a)
          if (e == h.vertex && k == h.xyz[a])
            xyz[a] = value;
        if (e == h.vertex && k == h.time)
          time = value;
      }
      if (e == h.vertex)
        cloud.add(xyz[0], xyz[1], xyz[2], i + 1, time);
    }
  }
}

} // namespace

pcl::PointCloud<pcl::PointXYZ>::Ptr
loadPlyScan(const std::string& path,
            double min_range,
            double max_range,
            std::vector<double>* point_times)
{
  std::error_code ec;
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec)
    fail(path, 0, "cannot determine the file size: " + ec.message());
  std::ifstream in = detail::openOrThrow(path, std::ios::in | std::ios::binary);
  const PlyHeader h = readPlyHeader(path, in, size);
  detail::RangeFilteredCloud cloud(path, min_range, max_range);
  cloud.keepTimes(point_times, h.time != detail::kNoField);
  if (h.format == PlyFormat::Ascii)
    readAscii(path, in, h, cloud);
  else
    readBinary(path, in, h, cloud);
  return cloud.finish();
}

// PLY 1.0 (Turk, "The PLY polygon file format"), as PCL reads it.
void
writePlyScan(const std::string& path, const pcl::PointCloud<pcl::PointXYZ>& cloud)
{
  const std::uint16_t one = 1;
  const bool little = *reinterpret_cast<const unsigned char*>(&one) == 1;
  std::ostringstream h;
  h << "ply\nformat " << (little ? "binary_little_endian" : "binary_big_endian")
    << " 1.0\ncomment pcl_pslam map\nelement vertex " << cloud.size()
    << "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
  detail::writeXyzFile(path, h.str(), cloud);
}

} // namespace io
} // namespace pcl_parallel
