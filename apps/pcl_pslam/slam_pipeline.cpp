/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "slam_pipeline.h"

#include <pcl_parallel/registration/icp.h>
#include <pcl_parallel/registration/loop_detection.h>
#include <pcl_parallel/registration/lum.h>
#include <pcl_parallel/registration/lum_solver.h>
#include <pcl_parallel/slam/pipeline.h>

#include <pcl/common/transforms.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/io/png_io.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <cmath>
#include <fstream>
#include <stdexcept>

namespace pcl_pslam {

Cloud::Ptr
reduce(const Cloud::ConstPtr& scan, double voxel_size)
{
  Cloud::Ptr out(new Cloud);
  if (!(voxel_size > 0.0)) {
    *out = *scan;
    return out;
  }
  pcl::VoxelGrid<pcl::PointXYZ> grid;
  grid.setInputCloud(scan);
  const float leaf = static_cast<float>(voxel_size);
  grid.setLeafSize(leaf, leaf, leaf);
  grid.filter(*out);
  return out;
}

Result
run(const std::vector<Cloud::Ptr>& scans,
    const Poses& initial,
    const Parameters& params,
    const Progress& progress)
{
  const int n = static_cast<int>(scans.size());
  if (n < 2)
    throw std::invalid_argument("pcl_pslam: needs at least 2 scans, got " + std::to_string(n));
  if (initial.size() != scans.size())
    throw std::invalid_argument("pcl_pslam: " + std::to_string(initial.size()) +
                                " initial poses for " + std::to_string(n) + " scans");
  pcl_parallel::slam::Pipeline pipeline(params);
  for (int i = 0; i < n; ++i) {
    if (!scans[i] || scans[i]->empty())
      throw std::invalid_argument("pcl_pslam: scan " + std::to_string(i) + " is empty");
    pipeline.addScan(*scans[i], params.odometry ? std::optional<Eigen::Matrix4d>(initial[i]) : std::nullopt);
    if (progress)
      progress("icp", i + 1, n);
  }
  pipeline.finish();
  Result result;
  result.icp = pipeline.frontEndPoses();
  result.final = pipeline.poses();
  for (const auto& l : pipeline.links())
    if (l.loop)
      result.links.emplace_back(l.source, l.target);
  for (const auto& r : pipeline.reports())
    result.icp_failures += r.converged ? 0 : 1;
  for (const auto& r : pipeline.reports())
    result.lum_iterations += r.lum_iterations;
  for (int i = 0; i < n; ++i)
    result.reduced.push_back(std::const_pointer_cast<Cloud>(pipeline.reducedScan(i)));
  result.times = pipeline.times();
  result.reports = pipeline.reports();
  result.relaxations = pipeline.relaxations();
  result.bytes_per_scan = pipeline.bytesPerScan();
  result.front_end = pipeline.frontEndParameters();
  result.loop_closure = pipeline.loopClosureParameters();
  return result;
}

Cloud::Ptr
mergedMap(const std::vector<Cloud::Ptr>& scans, const Poses& poses, double voxel_size)
{
  Cloud::Ptr map(new Cloud);
  for (std::size_t i = 0; i < scans.size(); ++i) {
    Cloud moved;
    pcl::transformPointCloud(*scans[i], moved, poses[i]);
    *map += moved;
  }
  return reduce(map, voxel_size);
}

void
writeTopView(
    const std::string& path, const Cloud& map, const Poses& trajectory, int up, int size)
{
  const int u = (up + 1) % 3, v = (up + 2) % 3; // image axes, right-handed about `up`
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  auto extend = [&](double a, double b) {
    lo = lo.cwiseMin(Eigen::Vector2d(a, b));
    hi = hi.cwiseMax(Eigen::Vector2d(a, b));
  };
  for (const auto& p : map)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
      extend(p.data[u], p.data[v]);
  for (const auto& t : trajectory)
    extend(t(u, 3), t(v, 3));
  if (!(hi.x() >= lo.x()))
    lo = hi = Eigen::Vector2d::Zero();
  const double extent = std::max({hi.x() - lo.x(), hi.y() - lo.y(), 1e-6});
  const double scale = (size - 1) / extent;
  const int width = std::max(1, static_cast<int>((hi.x() - lo.x()) * scale) + 1);
  const int height = std::max(1, static_cast<int>((hi.y() - lo.y()) * scale) + 1);
  auto pixel = [&](double a, double b) {
    return std::make_pair(static_cast<int>((a - lo.x()) * scale),
                          height - 1 - static_cast<int>((b - lo.y()) * scale));
  };
  // Like a floor plan: points near the scanner's height (where walls and obstacles are,
  // floor and ceiling are not) dark by log density, all others light grey.
  double low = 1e300, high = -1e300;
  for (const auto& t : trajectory) {
    low = std::min(low, t(up, 3));
    high = std::max(high, t(up, 3));
  }
  low -= 0.8, high += 0.8;
  std::vector<unsigned> band(static_cast<std::size_t>(width) * height, 0);
  std::vector<char> seen(band.size(), 0);
  for (const auto& p : map) {
    if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)))
      continue;
    const auto [x, y] = pixel(p.data[u], p.data[v]);
    const std::size_t k = static_cast<std::size_t>(y) * width + x;
    seen[k] = 1;
    if (p.data[up] >= low && p.data[up] <= high)
      ++band[k];
  }
  const unsigned peak = std::max(1u, *std::max_element(band.begin(), band.end()));
  std::vector<unsigned char> rgb(band.size() * 3, 255);
  for (std::size_t k = 0; k < band.size(); ++k) {
    unsigned char shade = 255;
    if (band[k])
      shade =
          static_cast<unsigned char>(150.0 * (1.0 - std::log1p(band[k]) / std::log1p(peak)));
    else if (seen[k])
      shade = 225;
    rgb[3 * k] = rgb[3 * k + 1] = rgb[3 * k + 2] = shade;
  }
  for (const auto& t : trajectory) { // 3x3 red dot per pose
    const auto [x, y] = pixel(t(u, 3), t(v, 3));
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int px = x + dx, py = y + dy;
        if (px < 0 || py < 0 || px >= width || py >= height)
          continue;
        unsigned char* c = &rgb[3 * (static_cast<std::size_t>(py) * width + px)];
        c[0] = 220, c[1] = 0, c[2] = 0;
      }
  }
  std::ofstream probe(path, std::ios::binary); // PCL's writer does not report failures
  if (!probe)
    throw std::runtime_error("pcl_pslam: cannot write " + path);
  probe.close();
  pcl::io::saveRgbPNGFile(path, rgb.data(), width, height);
}

void
writePoses(const std::string& path, const Poses& poses)
{
  std::ofstream out(path);
  if (!out)
    throw std::runtime_error("pcl_pslam: cannot write " + path);
  out.precision(10);
  for (const auto& p : poses) {
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        out << p(r, c) << (r == 2 && c == 3 ? '\n' : ' ');
  }
  if (!out)
    throw std::runtime_error("pcl_pslam: error writing " + path);
}

Errors
poseErrors(const Poses& a, const Poses& b)
{
  Errors e;
  const std::size_t n = std::min(a.size(), b.size());
  for (std::size_t i = 0; i < n; ++i) {
    double r, t;
    pcl_parallel::lum::poseError(a[i], b[i], r, t);
    e.max_rot = std::max(e.max_rot, r);
    e.max_trans = std::max(e.max_trans, t);
    e.mean_rot += r / static_cast<double>(n);
    e.mean_trans += t / static_cast<double>(n);
  }
  return e;
}

} // namespace pcl_pslam
