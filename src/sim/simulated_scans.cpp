/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/sim/simulated_scans.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>

namespace pcl_parallel {
namespace sim {

namespace {

Eigen::Matrix4d
planarPose(double x, double y, double z, double heading)
{
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() =
      Eigen::AngleAxisd(heading, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  m.topRightCorner<3, 1>() = Eigen::Vector3d(x, y, z);
  return m;
}

void
validate(const SimulationParameters& p)
{
  const auto bad = [](const char* what) {
    throw std::invalid_argument(std::string("[pcl_parallel::sim] ") + what);
  };
  if (!(p.corridor_width >= 2.5))
    bad("corridor_width must be at least 2.5 m");
  if (!(p.outer_length > 2.0 * p.corridor_width + 1.0) ||
      !(p.outer_width > 2.0 * p.corridor_width + 1.0))
    bad("the floor must be larger than two corridors plus a 1 m inner block");
  if (!(p.height > p.scanner_height && p.scanner_height > 0.0))
    bad("the scanner must be between floor and ceiling");
  if (!(p.step_length > 0.0) || !(p.laps > 0.0))
    bad("step_length and laps must be positive");
  if (!(p.obstacle_spacing >= 0.0))
    bad("obstacle_spacing must not be negative");
  if (p.scanner.sweep_period != 0.0)
    bad("the corridor set is stop-and-go: scanner.sweep_period must be 0");
  sim::validate(p.scanner);
  if (!(p.odometry_heading_noise >= 0.0) || !(p.odometry_translation_noise >= 0.0))
    bad("odometry noise must not be negative");
}

} // namespace

World
makeCorridorWorld(const SimulationParameters& p)
{
  validate(p);
  const double l = p.outer_length, w = p.outer_width, c = p.corridor_width, h = p.height;
  const double wall = 0.2;
  World world;
  // Floor, ceiling, the four outer walls, the inner block.
  world.boxes.push_back({{-wall, -wall, -wall}, {l + wall, w + wall, 0.0}});
  world.boxes.push_back({{-wall, -wall, h}, {l + wall, w + wall, h + wall}});
  world.boxes.push_back({{-wall, -wall, 0.0}, {0.0, w + wall, h}});
  world.boxes.push_back({{l, -wall, 0.0}, {l + wall, w + wall, h}});
  world.boxes.push_back({{0.0, -wall, 0.0}, {l, 0.0, h}});
  world.boxes.push_back({{0.0, w, 0.0}, {l, w + wall, h}});
  world.boxes.push_back({{c, c, 0.0}, {l - c, w - c, h}});

  // Crates and pillars along both walls of the corridor (the outer walls and the inner
  // block's faces), each at most a quarter of the corridor deep, so the centre line
  // stays clear by at least half the corridor width.
  std::mt19937 rng(p.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  struct Wall {
    Eigen::Vector2d start, along, inward; // inward: into the corridor
    double length;
  };
  const Wall walls[8] = {{{0, 0}, {1, 0}, {0, 1}, l},
                         {{l, 0}, {0, 1}, {-1, 0}, w},
                         {{l, w}, {-1, 0}, {0, -1}, l},
                         {{0, w}, {0, -1}, {1, 0}, w},
                         {{c, c}, {1, 0}, {0, -1}, l - 2 * c},
                         {{l - c, c}, {0, 1}, {1, 0}, w - 2 * c},
                         {{l - c, w - c}, {-1, 0}, {0, 1}, l - 2 * c},
                         {{c, w - c}, {0, -1}, {-1, 0}, w - 2 * c}};
  const double max_depth = std::min(1.0, 0.25 * c);
  for (const Wall& wall : walls) {
    const int count =
        p.obstacle_spacing > 0.0
            ? std::max(1, static_cast<int>(std::lround(wall.length / p.obstacle_spacing)))
            : 0;
    for (int k = 0; k < count; ++k) {
      const double s = wall.length * (k + 0.2 + 0.6 * unit(rng)) / count;
      const Eigen::Vector2d base = wall.start + s * wall.along;
      if (unit(rng) < 0.5) { // crate against the wall
        const double depth = max_depth * (0.3 + 0.7 * unit(rng));
        const double width = 0.4 + 0.8 * unit(rng), top = 0.5 + 1.5 * unit(rng);
        const Eigen::Vector2d a = base - 0.5 * width * wall.along;
        const Eigen::Vector2d b = base + 0.5 * width * wall.along + depth * wall.inward;
        world.boxes.push_back({{std::min(a.x(), b.x()), std::min(a.y(), b.y()), 0.0},
                               {std::max(a.x(), b.x()), std::max(a.y(), b.y()), top}});
      }
      else { // pillar a little off the wall
        const double r = max_depth * (0.12 + 0.18 * unit(rng));
        const double gap = max_depth * (0.1 + 0.3 * unit(rng));
        const Eigen::Vector2d centre = base + (r + gap) * wall.inward;
        world.cylinders.push_back({centre.x(), centre.y(), r, 0.0, h});
      }
    }
  }
  return world;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr
simulateScan(const World& world,
             const ScannerModel& scanner,
             const Eigen::Matrix4d& pose,
             std::uint32_t seed,
             unsigned num_threads)
{
  return castScan(RayCaster(world), scanner, pose, scanKey(seed, 0), num_threads);
}

SimulatedScanSet
simulateScanSet(const SimulationParameters& p, unsigned num_threads)
{
  SimulatedScanSet set;
  set.world = makeCorridorWorld(p); // validates p
  // The centre line of the ring corridor, driven counter-clockwise from a corner.
  const double half = 0.5 * p.corridor_width;
  const double lx = p.outer_length - p.corridor_width, ly = p.outer_width - p.corridor_width;
  const double perimeter = 2.0 * (lx + ly);
  // Checked before the cast to int (UB beyond INT_MAX, e.g. for a tiny step_length).
  const double steps = std::floor(p.laps * perimeter / p.step_length);
  constexpr double kMaxScans = 1e6;
  if (!(steps < kMaxScans))
    throw std::invalid_argument("[pcl_parallel::sim] laps * perimeter / step_length gives " +
                                std::to_string(steps) + " scans, more than 1e6");
  const int n = static_cast<int>(steps) + 1;
  for (int i = 0; i < n; ++i) {
    double s = std::fmod(i * p.step_length, perimeter);
    double x, y, heading;
    if (s < lx)
      x = half + s, y = half, heading = 0.0;
    else if ((s -= lx) < ly)
      x = half + lx, y = half + s, heading = 0.5 * M_PI;
    else if ((s -= ly) < lx)
      x = half + lx - s, y = half + ly, heading = M_PI;
    else
      s -= lx, x = half, y = half + ly - s, heading = 1.5 * M_PI;
    set.truth.push_back(planarPose(x, y, p.scanner_height, heading));
  }

  // Odometry: the true step between consecutive poses, disturbed, accumulated.
  std::mt19937 rng(p.seed ^ 0x9e3779b9u);
  std::normal_distribution<double> g(0.0, 1.0);
  set.odometry.push_back(set.truth[0]);
  for (int i = 1; i < n; ++i) {
    const Eigen::Matrix4d step = set.truth[i - 1].inverse() * set.truth[i];
    const double length = step.topRightCorner<3, 1>().norm();
    const Eigen::Matrix4d error = planarPose(p.odometry_translation_noise * length * g(rng),
                                             p.odometry_translation_noise * length * g(rng),
                                             0.0,
                                             p.odometry_heading_noise * g(rng));
    set.odometry.push_back(set.odometry.back() * step * error);
  }

  const RayCaster caster(set.world);
  set.scans.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    const auto k = static_cast<std::size_t>(i);
    set.scans[k] = castScan(caster, p.scanner, set.truth[k], scanKey(p.seed, k), num_threads);
    set.timestamps.push_back(static_cast<double>(i));
  }
  set.scanner = p.scanner;
  set.name = "corridor";
  return set;
}

} // namespace sim
} // namespace pcl_parallel
