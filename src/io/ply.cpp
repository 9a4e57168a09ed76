/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/io/ply.h>

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

namespace pcl_parallel {
namespace io {

pcl::PointCloud<pcl::PointXYZ>::Ptr
loadAsciiPlyVertices(const std::string& path)
{
  std::ifstream in(path);
  if (!in)
    throw std::runtime_error("cannot open PLY file " + path);
  auto fail = [&](const std::string& what) {
    throw std::runtime_error("PLY file " + path + ": " + what);
  };
  std::string line;
  if (!std::getline(in, line) || line.rfind("ply", 0) != 0)
    fail("missing 'ply' magic");
  std::size_t vertex_count = 0;
  bool in_vertex = false, seen_vertex = false, ascii = false;
  std::vector<std::string> props; // vertex property names, in order
  bool header_done = false;
  while (std::getline(in, line)) {
    std::istringstream ls(line);
    std::string kw;
    ls >> kw;
    if (kw == "format") {
      std::string fmt;
      ls >> fmt;
      ascii = fmt == "ascii";
    }
    else if (kw == "element") {
      std::string name;
      std::size_t count = 0;
      ls >> name >> count;
      in_vertex = name == "vertex";
      if (in_vertex) {
        if (seen_vertex)
          fail("two vertex elements");
        seen_vertex = true;
        vertex_count = count;
      }
      else if (!seen_vertex)
        fail("elements before 'vertex' are not supported");
    }
    else if (kw == "property" && in_vertex) {
      std::string type, name;
      ls >> type;
      if (type == "list")
        fail("list property in vertex element");
      ls >> name;
      props.push_back(name);
    }
    else if (kw == "end_header") {
      header_done = true;
      break;
    }
  }
  if (!header_done)
    fail("no end_header");
  if (!ascii)
    fail("only ASCII PLY is supported");
  int ix = -1, iy = -1, iz = -1;
  for (std::size_t i = 0; i < props.size(); ++i) {
    if (props[i] == "x")
      ix = static_cast<int>(i);
    else if (props[i] == "y")
      iy = static_cast<int>(i);
    else if (props[i] == "z")
      iz = static_cast<int>(i);
  }
  if (ix < 0 || iy < 0 || iz < 0)
    fail("vertex element lacks x, y or z");

  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->reserve(vertex_count);
  std::vector<double> values(props.size());
  for (std::size_t v = 0; v < vertex_count; ++v) {
    if (!std::getline(in, line))
      fail("only " + std::to_string(v) + " of " + std::to_string(vertex_count) + " vertices");
    std::istringstream ls(line);
    for (double& x : values)
      if (!(ls >> x))
        fail("malformed vertex line " + std::to_string(v));
    cloud->push_back(pcl::PointXYZ(static_cast<float>(values[ix]),
                                   static_cast<float>(values[iy]),
                                   static_cast<float>(values[iz])));
  }
  return cloud;
}

} // namespace io
} // namespace pcl_parallel
