/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
// The C++ side of the Python tests (test/python/): the library's own calls on the same
// data, written without the bindings, their results as raw little-endian doubles (and
// int64 indices) that the tests compare bit for bit with the module's.
//
//   icp  SRC TGT INIT_KITTI OUT min_range max_range max_distance iterations metric threads
//   knn  CLOUD QUERIES OUT k max_distance threads
//   lum  DIR POSES_KITTI LINKS OUT min_range max_range distance final iterations epsilon
//   threads

#include <pcl_parallel/io/scan_directory.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/registration/icp.h>
#include <pcl_parallel/registration/lum.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

namespace {

using Icp = pcl_parallel::registration::
    ParallelIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ, float>;

struct IcpPeek : Icp {
  static int
  iterations(const Icp& icp)
  {
    return icp.*(&IcpPeek::nr_iterations_);
  }
};

template <typename T>
void
write(std::ofstream& out, const std::vector<T>& v)
{
  out.write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * sizeof(T)));
}

int
icp(char** a)
{
  const auto source = pcl_parallel::io::loadScan(a[0], std::stod(a[4]), std::stod(a[5]));
  const auto target = pcl_parallel::io::loadScan(a[1], std::stod(a[4]), std::stod(a[5]));
  const Eigen::Matrix4d init = pcl_parallel::io::loadKittiPoses(a[2]).at(0);
  Icp reg;
  reg.setNumberOfThreads(unsigned(std::stoul(a[9])));
  reg.setInputSource(source);
  reg.setInputTarget(target);
  if (std::isfinite(std::stod(a[6])))
    reg.setMaxCorrespondenceDistance(std::stod(a[6]));
  reg.setMaximumIterations(std::stoi(a[7]));
  reg.setTransformationEpsilon(1e-8);
  reg.setUsePointToPlane(std::string(a[8]) == "point_to_plane");
  pcl::PointCloud<pcl::PointXYZ> aligned;
  reg.alignDouble(aligned, init);
  std::vector<double> out;
  const Eigen::Matrix4d t = reg.getFinalTransformationDouble();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      out.push_back(t(r, c));
  out.push_back(reg.hasConverged() ? 1.0 : 0.0);
  out.push_back(reg.getFitnessScore());
  out.push_back(IcpPeek::iterations(reg));
  std::ofstream file(a[3], std::ios::binary);
  write(file, out);
  return 0;
}

int
knn(char** a)
{
  const auto cloud = pcl_parallel::io::loadScan(a[0]);
  const auto queries = pcl_parallel::io::loadScan(a[1]);
  const std::size_t k = std::stoul(a[3]);
  const double max_distance = std::stod(a[4]);
  const float max_sqr = float(max_distance * max_distance);
  const unsigned threads = unsigned(std::stoul(a[5]));
  constexpr std::size_t stride = sizeof(pcl::PointXYZ) / sizeof(float);
  pcl_parallel::KdTreeIndex tree;
  tree.build(&(*cloud)[0].x, cloud->size(), stride, nullptr, threads);
  std::vector<std::int64_t> indices;
  std::vector<double> distances;
  const std::size_t n = queries->size();
  if (k == 1) {
    std::vector<std::uint32_t> pos(n);
    std::vector<float> sqr(n);
    tree.nearestBatch(&(*queries)[0].x, n, stride, max_sqr, pos.data(), sqr.data(), threads);
    for (std::size_t i = 0; i < n; ++i) {
      const bool found = pos[i] != pcl_parallel::KdTreeIndex::kInvalid;
      indices.push_back(found ? std::int64_t(tree.id(pos[i])) : -1);
      distances.push_back(found ? std::sqrt(double(sqr[i]))
                                : std::numeric_limits<double>::infinity());
    }
  }
  else {
    std::vector<std::uint32_t> pos(k);
    std::vector<float> sqr(k);
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t found = tree.knn(&(*queries)[i].x, k, pos.data(), sqr.data());
      for (std::size_t j = 0; j < k; ++j) {
        const bool ok = j < found && sqr[j] <= max_sqr;
        indices.push_back(ok ? std::int64_t(tree.id(pos[j])) : -1);
        distances.push_back(ok ? std::sqrt(double(sqr[j]))
                               : std::numeric_limits<double>::infinity());
      }
    }
  }
  std::ofstream file(a[2], std::ios::binary);
  write(file, indices);
  write(file, distances);
  return 0;
}

int
lum(char** a)
{
  pcl_parallel::io::ScanDirectoryOptions o;
  o.dir = a[0];
  o.min_range = std::stod(a[4]);
  o.max_range = std::stod(a[5]);
  const pcl_parallel::io::ScanDirectory dir = pcl_parallel::io::openScanDirectory(o);
  const auto poses = pcl_parallel::io::loadKittiPoses(a[1]);
  pcl_parallel::ParallelLUM<pcl::PointXYZ> lum;
  lum.setNumberOfThreads(unsigned(std::stoul(a[10])));
  for (std::size_t k = 0; k < dir.size(); ++k)
    lum.setPoseMatrix(lum.addPointCloud(pcl_parallel::io::readScan(dir, k),
                                        Eigen::Matrix4f::Identity().eval()),
                      poses.at(k));
  std::ifstream links(a[2]);
  for (std::size_t i, j; links >> i >> j;)
    lum.addLink(j, i);
  lum.setCorrespondenceDistanceSchedule(std::stod(a[6]), std::stod(a[7]), 0.7);
  lum.setMaxIterations(std::stoi(a[8]));
  lum.setConvergenceThreshold(float(std::stod(a[9])));
  lum.setPointToPlane(true);
  lum.compute();
  std::vector<double> out;
  for (std::size_t k = 0; k < dir.size(); ++k) {
    const Eigen::Matrix4d p = lum.getPoseMatrix(k);
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c)
        out.push_back(p(r, c));
  }
  std::ofstream file(a[3], std::ios::binary);
  write(file, out);
  return 0;
}

} // namespace

int
main(int argc, char** argv)
{
  const std::string mode = argc > 1 ? argv[1] : "";
  try {
    if (mode == "icp" && argc == 12)
      return icp(argv + 2);
    if (mode == "knn" && argc == 8)
      return knn(argv + 2);
    if (mode == "lum" && argc == 13)
      return lum(argv + 2);
  }
  catch (const std::exception& e) {
    std::cerr << "pcl_parallel_py_reference: " << e.what() << '\n';
    return 1;
  }
  std::cerr << "usage: see test/python/reference.cpp\n";
  return 2;
}
