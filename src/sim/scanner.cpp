/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/sim/scanner.h>

#include <stdexcept>
#include <string>

namespace pcl_parallel {
namespace sim {

namespace {

/** SplitMix64's finaliser (Steele, Lea, Flood 2014): a bijective 64-bit mix. */
std::uint64_t
mix(std::uint64_t z)
{
  z += 0x9e3779b97f4a7c15ull;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

/** Uniform in (0, 1): 53 random bits, never 0 (Box-Muller takes its logarithm). */
double
unit(std::uint64_t h)
{
  return (static_cast<double>(h >> 11) + 0.5) * 0x1.0p-53;
}

/** Direction at a fractional column (mixed pixels look half a column on). */
Eigen::Vector3d
direction(const ScannerModel& s, double column, int row)
{
  const double f =
      s.elevation_steps > 1 ? static_cast<double>(row) / (s.elevation_steps - 1) : 0.0;
  if (s.pattern == ScannerModel::Pattern::TiltingLine) {
    const double beam = s.line_fov * (0.5 - f); // left to right
    const double pitch = s.azimuth_steps > 1
                             ? s.min_elevation + (s.max_elevation - s.min_elevation) * column /
                                                     (s.azimuth_steps - 1)
                             : s.min_elevation;
    // The fan (cos b, sin b, 0) pitched up by `pitch` about the y axis.
    return {std::cos(pitch) * std::cos(beam), std::sin(beam), std::sin(pitch) * std::cos(beam)};
  }
  const double azimuth = M_PI * (1.0 - 2.0 * (column + 0.5) / s.azimuth_steps);
  const double elevation = s.min_elevation + (s.max_elevation - s.min_elevation) * f;
  return {std::cos(elevation) * std::cos(azimuth),
          std::cos(elevation) * std::sin(azimuth),
          std::sin(elevation)};
}

} // namespace

double
counterUniform(std::uint64_t key, std::uint64_t ray)
{
  return unit(mix(key ^ mix(2 * ray)));
}

double
counterNormal(std::uint64_t key, std::uint64_t ray)
{
  // Box-Muller from two counter-based uniforms.
  const double u1 = unit(mix(key ^ mix(2 * ray + 1))), u2 = counterUniform(key, ray);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

std::uint64_t
scanKey(std::uint64_t seed, std::uint64_t scan)
{
  return mix(mix(seed) + scan);
}

Eigen::Vector3d
rayDirection(const ScannerModel& scanner, int column, int row)
{
  return direction(scanner, column, row);
}

void
validate(const ScannerModel& s)
{
  const auto bad = [](const std::string& what) {
    throw std::invalid_argument("[pcl_parallel::sim] invalid scanner model: " + what);
  };
  if (s.azimuth_steps < 1 || s.elevation_steps < 1)
    bad("azimuth_steps and elevation_steps must be at least 1");
  if (!(s.min_range >= 0.0) || !(s.max_range > s.min_range) || !std::isfinite(s.max_range))
    bad("need 0 <= min_range < max_range < inf");
  if (!(s.range_noise >= 0.0) || !(s.max_elevation >= s.min_elevation))
    bad("range_noise must not be negative, max_elevation not below min_elevation");
  if (!(s.mixed_pixel_probability >= 0.0 && s.mixed_pixel_probability <= 1.0) ||
      !(s.mixed_pixel_gap > 0.0))
    bad("mixed_pixel_probability must lie in [0, 1], mixed_pixel_gap be positive");
  if (!(s.sweep_period >= 0.0) ||
      (s.sweep_period > 0.0 && s.pattern != ScannerModel::Pattern::Spherical))
    bad("sweep_period must not be negative, and only a Spherical scanner sweeps");
  if (!(s.line_fov > 0.0 && s.line_fov <= 2.0 * M_PI))
    bad("line_fov must lie in (0, 2 pi]");
}

pcl::PointCloud<pcl::PointXYZ>::Ptr
castScan(const RayCaster& caster,
         const ScannerModel& s,
         const std::function<Eigen::Matrix4d(int column)>& pose_of_column,
         std::uint64_t key,
         unsigned num_threads,
         std::vector<float>* times)
{
  validate(s);
  const int columns = s.azimuth_steps, rows = s.elevation_steps;
  // Poses first, serially: pose_of_column need not be thread-safe.
  std::vector<Eigen::Matrix4d> poses(static_cast<std::size_t>(columns));
  for (int c = 0; c < columns; ++c)
    poses[static_cast<std::size_t>(c)] = pose_of_column(c);
  std::vector<std::vector<pcl::PointXYZ>> per_column(static_cast<std::size_t>(columns));
  const unsigned threads = resolveNumberOfThreads(num_threads);
  parallelFor(
      static_cast<std::size_t>(columns), threads, 4, [&](std::size_t c0, std::size_t c1) {
        for (int c = static_cast<int>(c0); c < static_cast<int>(c1); ++c) {
          const Eigen::Matrix4d& pose = poses[static_cast<std::size_t>(c)];
          const Eigen::Matrix3d r = pose.topLeftCorner<3, 3>();
          const Eigen::Vector3d origin = pose.topRightCorner<3, 1>();
          auto& out = per_column[static_cast<std::size_t>(c)];
          out.reserve(static_cast<std::size_t>(rows));
          for (int row = 0; row < rows; ++row) {
            const std::uint64_t ray = static_cast<std::uint64_t>(c) * rows + row;
            const Eigen::Vector3d d = direction(s, c, row);
            double range;
            if (!caster.raycast(origin, r * d, s.max_range, range)) {
              if (s.max_range_points)
                out.emplace_back(static_cast<float>(s.max_range * d.x()),
                                 static_cast<float>(s.max_range * d.y()),
                                 static_cast<float>(s.max_range * d.z()));
              continue;
            }
            if (s.mixed_pixel_probability > 0.0) { // a footprint across a depth edge
              double other;
              const Eigen::Vector3d half = direction(s, c + 0.5, row);
              if (caster.raycast(origin, r * half, s.max_range, other) &&
                  std::abs(other - range) > s.mixed_pixel_gap &&
                  counterUniform(key ^ 0x6d69786564ull, ray) < s.mixed_pixel_probability)
                range += counterUniform(key ^ 0x7765696768ull, ray) * (other - range);
            }
            if (s.range_noise > 0.0)
              range += s.range_noise * counterNormal(key, ray);
            if (range < s.min_range || range > s.max_range)
              continue;
            out.emplace_back(static_cast<float>(range * d.x()),
                             static_cast<float>(range * d.y()),
                             static_cast<float>(range * d.z()));
          }
        }
      });
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  std::size_t total = 0;
  for (const auto& col : per_column)
    total += col.size();
  cloud->reserve(total);
  if (times) {
    times->clear();
    times->reserve(total);
  }
  for (int c = 0; c < columns; ++c) {
    const auto& col = per_column[static_cast<std::size_t>(c)];
    cloud->insert(cloud->end(), col.begin(), col.end());
    if (times)
      times->insert(times->end(), col.size(), static_cast<float>((c + 0.5) / columns));
  }
  return cloud;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr
castScan(const RayCaster& caster,
         const ScannerModel& scanner,
         const Eigen::Matrix4d& pose,
         std::uint64_t key,
         unsigned num_threads)
{
  return castScan(
      caster, scanner, [&pose](int) { return pose; }, key, num_threads);
}

} // namespace sim
} // namespace pcl_parallel
