/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The presets: three scenes built from primitives (an office floor, a building with a
 * grid of corridors, a street around a block with a square), closed routes over them,
 * scanner models and drifting odometry. docs/design.md ("Simulator") has the layouts.
 */
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/sim/presets.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

namespace pcl_parallel {
namespace sim {

namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kUpperFloor = 3.2; ///< the split-level building's east wing, metres up
constexpr int kStairs = 18;         ///< steps of each flight
/** The stairwells between the split-level building's wings: from x = kStairsWest (the
 *  west wing's open side) to kStairsEast (the east wing's). */
constexpr double kStairsWest = 16.0, kStairsEast = 21.0;

/** SplitMix64 (Steele et al. 2014): a portable sequence for laying out scenes; the
 *  standard distributions are implementation-defined. */
class Rng {
public:
  explicit Rng(std::uint64_t seed)
      : state_(seed)
  {}
  double
  uniform(double lo = 0.0, double hi = 1.0)
  {
    std::uint64_t z = (state_ += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    z ^= z >> 31;
    return lo + (hi - lo) * (static_cast<double>(z >> 11) * 0x1.0p-53);
  }
  double
  normal()
  {
    const double u1 = 1.0 - uniform(), u2 = uniform();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
  }

private:
  std::uint64_t state_;
};

using Height = std::function<double(double, double)>;

void
box(World& w, double x0, double y0, double z0, double x1, double y1, double z1)
{
  w.boxes.push_back({{std::min(x0, x1), std::min(y0, y1), std::min(z0, z1)},
                     {std::max(x0, x1), std::max(y0, y1), std::max(z0, z1)}});
}

void
orientedBox(World& w,
            const Eigen::Vector3d& centre,
            const Eigen::Vector3d& half,
            double yaw,
            double pitch,
            double roll)
{
  OrientedBox b;
  b.rotation = eulerZYXToRotation(roll, pitch, yaw);
  b.centre = centre;
  b.half_size = half;
  w.oriented_boxes.push_back(b);
}

/** An axis-aligned wall from a to b (same x or same y), `thick` thick, with doors (1 m
 *  wide, 2.1 m high, lintel above) centred at the given distances from a. */
void
wall(World& w,
     const Eigen::Vector2d& a,
     const Eigen::Vector2d& b,
     double thick,
     double height,
     std::vector<double> doors = {})
{
  const bool along_x = std::abs(a.y() - b.y()) < 1e-9;
  const double s0 = along_x ? std::min(a.x(), b.x()) : std::min(a.y(), b.y());
  const double s1 = along_x ? std::max(a.x(), b.x()) : std::max(a.y(), b.y());
  const double c = along_x ? a.y() : a.x(), h = 0.5 * thick;
  const double start = along_x ? a.x() : a.y(),
               sign = (along_x ? b.x() - a.x() : b.y() - a.y()) >= 0 ? 1 : -1;
  const auto piece = [&](double u0, double u1, double z0, double z1) {
    if (u1 - u0 < 1e-6)
      return;
    if (along_x)
      box(w, u0, c - h, z0, u1, c + h, z1);
    else
      box(w, c - h, u0, z0, c + h, u1, z1);
  };
  std::vector<std::pair<double, double>> gaps;
  for (double d : doors) {
    const double m = start + sign * d;
    gaps.emplace_back(m - 0.5, m + 0.5);
  }
  std::sort(gaps.begin(), gaps.end());
  double u = s0;
  for (const auto& [g0, g1] : gaps) {
    piece(u, g0, 0.0, height);
    piece(g0, g1, 2.1, height); // lintel
    u = g1;
  }
  piece(u, s1, 0.0, height);
}

/** Floor slab, ceiling slab and the four outer walls of a rectangular storey. */
void
shell(World& w, double lx, double ly, double height)
{
  box(w, -0.3, -0.3, -0.3, lx + 0.3, ly + 0.3, 0.0);
  box(w, -0.3, -0.3, height, lx + 0.3, ly + 0.3, height + 0.3);
  wall(w, {-0.1, -0.1}, {lx + 0.1, -0.1}, 0.2, height);
  wall(w, {-0.1, ly + 0.1}, {lx + 0.1, ly + 0.1}, 0.2, height);
  wall(w, {-0.1, -0.1}, {-0.1, ly + 0.1}, 0.2, height);
  wall(w, {lx + 0.1, -0.1}, {lx + 0.1, ly + 0.1}, 0.2, height);
}

/** Desks and cabinets inside the room [x0, x1] x [y0, y1], against its walls. */
void
furnish(World& w, Rng& rng, double x0, double y0, double x1, double y1)
{
  const int n = 2 + static_cast<int>(rng.uniform(0.0, 3.0));
  for (int k = 0; k < n; ++k) {
    const bool cabinet = rng.uniform() < 0.4;
    const double dx = cabinet ? 0.5 : 1.4, dy = cabinet ? 1.0 : 0.7;
    const double top = cabinet ? rng.uniform(1.2, 2.0) : 0.75;
    const bool swap = rng.uniform() < 0.5;
    const double sx = swap ? dy : dx, sy = swap ? dx : dy;
    if (x1 - x0 < sx + 0.6 || y1 - y0 < sy + 0.6)
      continue;
    const double x = rng.uniform(x0 + 0.2, x1 - 0.2 - sx),
                 y = rng.uniform(y0 + 0.2, y1 - 0.2 - sy);
    box(w, x, y, 0.0, x + sx, y + sy, top);
  }
}

/** Crates, bins and pillars along a corridor wall: from a along `along` for `length`
 *  metres, pushed in the direction `inward`, never deeper than `depth`. */
void
clutter(World& w,
        Rng& rng,
        const Eigen::Vector2d& a,
        const Eigen::Vector2d& along,
        const Eigen::Vector2d& inward,
        double length,
        double spacing,
        double depth,
        double height)
{
  const int count = std::max(1, static_cast<int>(std::lround(length / spacing)));
  for (int k = 0; k < count; ++k) {
    const double s = length * (k + 0.2 + 0.6 * rng.uniform()) / count;
    const Eigen::Vector2d base = a + s * along;
    if (rng.uniform() < 0.6) {
      const double d = depth * rng.uniform(0.4, 1.0), wdt = rng.uniform(0.4, 1.2);
      const Eigen::Vector2d p = base - 0.5 * wdt * along,
                            q = base + 0.5 * wdt * along + d * inward;
      box(w, p.x(), p.y(), 0.0, q.x(), q.y(), rng.uniform(0.5, 2.0));
    }
    else {
      const double r = depth * rng.uniform(0.15, 0.3);
      const Eigen::Vector2d c = base + (r + depth * rng.uniform(0.05, 0.2)) * inward;
      w.cylinders.push_back({c.x(), c.y(), r, 0.0, height});
    }
  }
}

/** The office floor (13 x 14.5 m, 3 m high): a ring corridor round two central rooms,
 *  three rooms off it to the south and three to the north, halls with pillars and
 *  cabinets at both ends, furniture, a slanted ramp and a sloping ceiling panel. The
 *  corridors' centre lines make a 9 x 6 m loop: 10 steps of ~3 m with a stop at each
 *  corner, where the front-hemisphere scanner faces diagonally and sees both corridors
 *  (design.md: longer steps, or stops just past a turn, overlap too little to match). */
/** The office loop: from the west hall's centre (2, 4.25) this far east and north. */
const Eigen::Vector2d kOfficeLoop(9.0, 6.0);

World
officeWorld(std::uint32_t seed)
{
  Rng rng(seed * 0x100000001b3ull + 11);
  World w;
  const double h = 3.0, x0 = 4.0, x1 = kOfficeLoop.x(), y1 = 3.0 + kOfficeLoop.y();
  const double lx = x1 + 4.0, ly = y1 + 5.5;
  shell(w, lx, ly, h);
  // Central block [x0, x1] x [5.5, y1]: two rooms, doors to the corridors.
  const double bx = x1 - x0, by = y1 - 5.5, xm = x0 + bx * rng.uniform(0.4, 0.6);
  wall(w,
       {x0, 5.5},
       {x1, 5.5},
       0.15,
       h,
       {bx * rng.uniform(0.1, 0.3), bx * rng.uniform(0.6, 0.9)});
  wall(w, {x0, y1}, {x1, y1}, 0.15, h, {bx * rng.uniform(0.1, 0.3)});
  wall(w, {x0, 5.5}, {x0, y1}, 0.15, h, {by * rng.uniform(0.2, 0.8)});
  wall(w, {x1, 5.5}, {x1, y1}, 0.15, h);
  wall(w, {xm, 5.5}, {xm, y1}, 0.15, h, {by * rng.uniform(0.2, 0.8)});
  furnish(w, rng, x0 + 0.1, 5.6, xm - 0.1, y1 - 0.1);
  furnish(w, rng, xm + 0.1, 5.6, x1 - 0.1, y1 - 0.1);
  // Rooms to the south (y < 3) and to the north (y > y1 + 2.5).
  for (const double y : {3.0, y1 + 2.5}) {
    const double far = y < 5 ? 0.0 : ly, third = (x1 - x0) / 3;
    wall(w, {x0, y}, {x1, y}, 0.15, h, {0.5 * third, 1.5 * third, 2.5 * third});
    for (int k = 0; k <= 3; ++k)
      wall(w, {x0 + k * third, far}, {x0 + k * third, y}, 0.15, h);
    for (int k = 0; k < 3; ++k)
      furnish(w,
              rng,
              x0 + k * third + 0.1,
              std::min(y, far) + 0.1,
              x0 + (k + 1) * third - 0.1,
              std::max(y, far) - 0.1);
  }
  // Halls at both ends: pillars, a wheelchair ramp (8 degrees), a sloping ceiling panel.
  for (const double x : {0.9, 16.6})
    for (const double y : {2.0, 0.5 * ly, ly - 2.0})
      w.cylinders.push_back(
          {x + rng.uniform(-0.2, 0.2), y + rng.uniform(-0.5, 0.5), 0.2, 0.0, h});
  // Cabinets on each hall's far wall beside the corridor axes: seen from the corridor
  // and from the corner, they fix the position along the wall.
  for (const double x : {0.0, lx - 0.5})
    for (const double y : {4.25, y1 + 1.25})
      for (const double side : {-1.0, 1.0}) {
        const double y0 = y + side * rng.uniform(1.0, 1.6), width = rng.uniform(0.5, 1.0);
        box(w, x, y0, 0.0, x + 0.5, y0 + side * width, rng.uniform(1.2, 2.0));
      }
  orientedBox(w, {lx - 1.5, 1.2, 0.1}, {1.2, 0.6, 0.25}, 0.0, -8 * kDeg, 0.0);
  orientedBox(w, {1.5, 0.5 * ly, 2.4}, {1.2, 2.0, 0.05}, 0.0, 0.0, 15 * kDeg);
  // Bins and crates along the corridor walls.
  clutter(w, rng, {x0 + 0.5, 3.1}, {1, 0}, {0, 1}, bx - 1.0, 3.0, 0.5, h);
  clutter(w, rng, {x0 + 0.5, y1 + 2.4}, {1, 0}, {0, -1}, bx - 1.0, 3.0, 0.5, h);
  return w;
}

/** The building (60 x 37 m): 3 x 2 blocks of rooms with doors, 3 m corridors between
 *  and round them (so the corridors form six loops), clutter, lamps, a stair ramp. */
World
buildingWorld(std::uint32_t seed)
{
  Rng rng(seed * 0x100000001b3ull + 23);
  World w;
  const double bw = 16, bh = 14, cw = 3, h = 3.0;
  const double lx = 3 * bw + 4 * cw, ly = 2 * bh + 3 * cw;
  shell(w, lx, ly, h);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 2; ++j) {
      const double x0 = cw + i * (bw + cw), y0 = cw + j * (bh + cw), x1 = x0 + bw, y1 = y0 + bh;
      wall(w, {x0, y0}, {x1, y0}, 0.2, h, {rng.uniform(2, 6), rng.uniform(9, 14)});
      wall(w, {x0, y1}, {x1, y1}, 0.2, h, {rng.uniform(2, 14)});
      wall(w, {x0, y0}, {x0, y1}, 0.2, h, {rng.uniform(2, 12)});
      wall(w, {x1, y0}, {x1, y1}, 0.2, h, {rng.uniform(2, 12)});
      const double xm = x0 + rng.uniform(6, 10);
      wall(w, {xm, y0}, {xm, y1}, 0.15, h, {rng.uniform(2, 12)});
      furnish(w, rng, x0 + 0.1, y0 + 0.1, xm - 0.1, y1 - 0.1);
      furnish(w, rng, xm + 0.1, y0 + 0.1, x1 - 0.1, y1 - 0.1);
      // Clutter along the block's four faces, inside the corridors.
      clutter(w, rng, {x0, y0 - 0.1}, {1, 0}, {0, -1}, bw, 4.0, 0.6, h);
      clutter(w, rng, {x0, y1 + 0.1}, {1, 0}, {0, 1}, bw, 4.0, 0.6, h);
      clutter(w, rng, {x0 - 0.1, y0}, {0, 1}, {-1, 0}, bh, 4.0, 0.6, h);
      clutter(w, rng, {x1 + 0.1, y0}, {0, 1}, {1, 0}, bh, 4.0, 0.6, h);
    }
  // Ceiling lamps every 5 m along the corridors (structure overhead).
  for (int i = 0; i < 4; ++i)
    for (double y = 2; y < ly - 1; y += 5) {
      const double x = 0.5 * cw + i * (bw + cw);
      box(w, x - 0.15, y - 0.6, h - 0.15, x + 0.15, y + 0.6, h);
    }
  for (int j = 0; j < 3; ++j)
    for (double x = 4; x < lx - 1; x += 5) {
      const double y = 0.5 * cw + j * (bh + cw);
      box(w, x - 0.6, y - 0.15, h - 0.15, x + 0.6, y + 0.15, h);
    }
  // A stair ramp climbing against the west wall (slanted structure).
  orientedBox(w, {0.5, 10.0, 0.8}, {0.4, 3.0, 0.1}, 0.0, 0.0, 15 * kDeg);
  return w;
}

/** `w`'s primitives mirrored about the plane x = mirror_x (none: kept) and raised by dz,
 *  added to `out`. */
void
place(World& out, const World& w, std::optional<double> mirror_x, double dz)
{
  const double c = mirror_x.value_or(0.0), sx = mirror_x ? -1.0 : 1.0;
  const auto point = [&](const Eigen::Vector3d& p) {
    return Eigen::Vector3d(c + sx * (p.x() - c), p.y(), p.z() + dz);
  };
  for (const Box& b : w.boxes) {
    const Eigen::Vector3d p = point(b.min), q = point(b.max);
    box(out, p.x(), p.y(), p.z(), q.x(), q.y(), q.z()); // box() orders the corners
  }
  for (Cylinder cyl : w.cylinders) {
    cyl.x = point({cyl.x, 0, 0}).x(), cyl.z_min += dz, cyl.z_max += dz;
    out.cylinders.push_back(cyl);
  }
  const Eigen::Matrix3d m = Eigen::Vector3d(sx, 1.0, 1.0).asDiagonal();
  for (OrientedBox b : w.oriented_boxes) { // M (c + R u) = M c + (M R M) (M u)
    b.centre = point(b.centre), b.rotation = m * b.rotation * m;
    out.oriented_boxes.push_back(b);
  }
  for (const Triangle& t : w.triangles)
    out.triangles.push_back({point(t.a), point(t.b), point(t.c)});
}

/** One wing of the split-level building (16 x 16 m, 3 m high, open at x = 16 where the
 *  stairs meet it): halls along its west, south and north walls round a block of two
 *  rooms with doors, furniture, clutter and pillars. */
World
wing(Rng& rng)
{
  World w;
  const double l = 16.0, h = 3.0;
  box(w, -0.3, -0.3, -0.3, l, l + 0.3, 0.0); // floor and ceiling
  box(w, -0.3, -0.3, h, l, l + 0.3, h + 0.3);
  wall(w, {-0.1, -0.1}, {l, -0.1}, 0.2, h);
  wall(w, {-0.1, l + 0.1}, {l, l + 0.1}, 0.2, h);
  wall(w, {-0.1, -0.1}, {-0.1, l + 0.1}, 0.2, h);
  const double x0 = 4.5, y0 = 4.5, y1 = 11.5, xm = x0 + rng.uniform(4.0, 7.0);
  wall(w, {x0, y0}, {l, y0}, 0.15, h, {rng.uniform(1.0, 3.0), rng.uniform(7.0, 10.0)});
  wall(w, {x0, y1}, {l, y1}, 0.15, h, {rng.uniform(2.0, 9.0)});
  wall(w, {x0, y0}, {x0, y1}, 0.15, h, {rng.uniform(1.5, 5.5)});
  wall(w, {xm, y0}, {xm, y1}, 0.15, h, {rng.uniform(1.5, 5.5)});
  furnish(w, rng, x0 + 0.1, y0 + 0.1, xm - 0.1, y1 - 0.1);
  furnish(w, rng, xm + 0.1, y0 + 0.1, l - 0.1, y1 - 0.1);
  clutter(w, rng, {0.5, 0.0}, {1, 0}, {0, 1}, l - 1.0, 3.0, 0.6, h);
  clutter(w, rng, {0.5, l}, {1, 0}, {0, -1}, l - 1.0, 3.0, 0.6, h);
  clutter(w, rng, {0.0, 5.0}, {0, 1}, {1, 0}, 6.0, 2.5, 0.6, h);
  for (const double y : {1.3, l - 1.3}) // beside the halls' walking lines (y = 3, 13)
    w.cylinders.push_back({x0 + rng.uniform(2.0, 8.0), y, 0.25, 0.0, h});
  return w;
}

/** The split-level building (37 x 16 m): a west wing on the ground floor, an east wing
 *  3.2 m up, joined by two flights of 18 stairs (5 m, 32 degrees) in stairwells between
 *  them, each wing a mirror of the other's plan with its own rooms and furniture. */
World
splitLevelWorld(std::uint32_t seed)
{
  Rng rng(seed * 0x100000001b3ull + 53);
  World w;
  place(w, wing(rng), std::nullopt, 0.0);
  // Mirrored about the stairwells' middle: its open side at kStairsEast.
  place(w, wing(rng), 0.5 * (kStairsWest + kStairsEast), kUpperFloor);
  const double x0 = kStairsWest, x1 = kStairsEast, top = kUpperFloor + 3.0;
  box(w, x0, -0.3, top, x1, 16.3, top + 0.3); // the stairwells' ceiling
  box(w, x0 - 0.2, -0.3, 3.0, x0, 16.3, top); // the west wing's wall above it
  box(w, x0, 4.5, -0.3, x1, 11.5, top);       // solid between the stairwells
  for (const double y : {-0.3, 14.5})         // the stairwells' outer walls
    box(w, x0, y, -0.3, x1, y + 1.8, top);
  for (int k = 0; k < kStairs; ++k) { // both flights, climbing east
    const double run = (x1 - x0) / kStairs, rise = kUpperFloor / kStairs;
    box(w, x0 + k * run, -0.3, -0.3, x0 + (k + 1) * run, 16.3, (k + 1) * rise);
  }
  return w;
}

/** The split-level building's floor height under (x, y): the stairs as the slope a
 *  walker's head follows. */
double
splitLevelFloor(double x, double)
{
  return kUpperFloor * std::clamp((x - kStairsWest) / (kStairsEast - kStairsWest), 0.0, 1.0);
}

/** The street scene's ground: gentle undulations (slopes of 1-2 degrees) and a 1.5 m
 *  rise between x = 10 and x = 40 (up to 4.3 degrees). */
double
streetGround(double x, double y)
{
  const double u = std::clamp((x - 10.0) / 30.0, 0.0, 1.0);
  return 0.15 * std::sin(2 * M_PI * x / 37.0) * std::sin(2 * M_PI * y / 29.0) +
         0.08 * std::sin(2 * M_PI * (x + y) / 23.0) + 1.5 * u * u * (3.0 - 2.0 * u);
}

/** Ground as a height field of triangles, 2 m cells, over [x0, x1] x [y0, y1]. */
void
heightField(World& w, const Height& ground, double x0, double y0, double x1, double y1)
{
  const double cell = 2.0;
  const int nx = static_cast<int>(std::ceil((x1 - x0) / cell)),
            ny = static_cast<int>(std::ceil((y1 - y0) / cell));
  const auto p = [&](int i, int j) {
    const double x = x0 + i * cell, y = y0 + j * cell;
    return Eigen::Vector3d(x, y, ground(x, y));
  };
  for (int i = 0; i < nx; ++i)
    for (int j = 0; j < ny; ++j) {
      w.triangles.push_back({p(i, j), p(i + 1, j), p(i + 1, j + 1)});
      w.triangles.push_back({p(i, j), p(i + 1, j + 1), p(i, j + 1)});
    }
}

/** A row of buildings along a street: facades on the line from a along `along` for
 *  `length` metres, the buildings extending `inward` (away from the street), with gaps,
 *  setbacks, heights of 8-25 m and some pitched roofs. */
void
buildingRow(World& w,
            Rng& rng,
            const Eigen::Vector2d& a,
            const Eigen::Vector2d& along,
            const Eigen::Vector2d& inward,
            double length)
{
  double s = 0.0;
  while (s < length - 4.0) {
    const double front = std::min(rng.uniform(8.0, 22.0), length - s);
    const double setback = rng.uniform() < 0.3 ? rng.uniform(0.5, 2.0) : 0.0;
    const double depth = rng.uniform(10.0, 14.0), top = 1.0 + rng.uniform(8.0, 25.0);
    const Eigen::Vector2d p = a + s * along + setback * inward;
    const Eigen::Vector2d q = a + (s + front) * along + (setback + depth) * inward;
    box(w, p.x(), p.y(), -5.0, q.x(), q.y(), top);
    if (rng.uniform() < 0.4) { // a pitched roof slab over the front half
      const Eigen::Vector2d m = 0.5 * (p + q) - 0.25 * depth * inward;
      const double yaw = std::atan2(along.y(), along.x());
      orientedBox(w,
                  {m.x(), m.y(), top + 1.0},
                  {0.5 * front, 0.3 * depth, 0.15},
                  yaw,
                  0.0,
                  (inward.x() * along.y() - inward.y() * along.x() > 0 ? 1 : -1) * 25 * kDeg);
    }
    s += front + (rng.uniform() < 0.25 ? rng.uniform(3.0, 8.0) : 0.0); // alleys
  }
}

/** Trees, lamp posts and parked cars along a kerb from a along `along`; cars sit on the
 *  street side (`outward` from the pavement). */
void
streetFurniture(World& w,
                Rng& rng,
                const Height& ground,
                const Eigen::Vector2d& a,
                const Eigen::Vector2d& along,
                const Eigen::Vector2d& outward,
                double length)
{
  for (double s = rng.uniform(2, 8); s < length; s += rng.uniform(9.0, 15.0)) {
    const Eigen::Vector2d t = a + s * along - 1.2 * outward;
    const double g = ground(t.x(), t.y());
    if (rng.uniform() < 0.7) { // tree: trunk and crown
      w.cylinders.push_back({t.x(), t.y(), rng.uniform(0.15, 0.3), g - 1.0, g + 3.0});
      w.cylinders.push_back(
          {t.x(), t.y(), rng.uniform(1.5, 2.5), g + 3.0, g + rng.uniform(6.0, 9.0)});
    }
    else
      w.cylinders.push_back({t.x(), t.y(), 0.1, g - 1.0, g + 6.0});
  }
  for (double s = rng.uniform(1, 6); s < length - 5; s += rng.uniform(5.5, 14.0)) {
    const Eigen::Vector2d c = a + (s + 2.2) * along + 1.2 * outward;
    const double g = ground(c.x(), c.y()), yaw = std::atan2(along.y(), along.x());
    orientedBox(w, {c.x(), c.y(), g + 0.55}, {2.2, 0.9, 0.45}, yaw, 0.0, 0.0);
    const Eigen::Vector2d k = c - 0.3 * along;
    orientedBox(w, {k.x(), k.y(), g + 1.25}, {1.1, 0.8, 0.3}, yaw, 0.0, 0.0);
  }
}

/** The street scene: a 80 x 50 m block, a ring road round it (centre line 10 m from its
 *  facades), building rows across the road on three sides, a square to the east with a
 *  monument, trees and a tall tower behind it; uneven ground throughout. */
World
streetWorld(std::uint32_t seed)
{
  Rng rng(seed * 0x100000001b3ull + 37);
  World w;
  heightField(w, streetGround, -70.0, -70.0, 180.0, 120.0);
  // The central block's four sides (facades at x = 0, 80, y = 0, 50, building inwards).
  buildingRow(w, rng, {0, 0}, {1, 0}, {0, 1}, 80);
  buildingRow(w, rng, {80, 50}, {-1, 0}, {0, -1}, 80);
  buildingRow(w, rng, {0, 50}, {0, -1}, {1, 0}, 50);
  buildingRow(w, rng, {80, 0}, {0, 1}, {-1, 0}, 50);
  // Across the road: facades at y = -20 (south), y = 70 (north), x = -20 (west).
  buildingRow(w, rng, {-60, -20}, {1, 0}, {0, -1}, 160);
  buildingRow(w, rng, {-60, 70}, {1, 0}, {0, 1}, 160);
  buildingRow(w, rng, {-20, -60}, {0, 1}, {-1, 0}, 170);
  // East: the square [100, 150] x [-20, 70] with a tower and facades behind it.
  buildingRow(w, rng, {160, -60}, {0, 1}, {1, 0}, 170);
  box(w, 150, 18, -5, 158, 26, 40);                                          // tower
  orientedBox(w, {154, 22, 44}, {3.0, 3.0, 3.0}, 45 * kDeg, 0.0, 35 * kDeg); // spire
  const double g = streetGround(125, 25);
  box(w, 122, 22, -5, 128, 28, g + 1.5); // monument: plinth, column, statue
  w.cylinders.push_back({125, 25, 1.0, g + 1.5, g + 12});
  box(w, 124.2, 24.2, g + 12, 125.8, 25.8, g + 14.5);
  for (int k = 0; k < 10; ++k) { // a ring of trees round it
    const double a = 2 * M_PI * (k + rng.uniform(-0.2, 0.2)) / 10, r = rng.uniform(10, 13);
    const double x = 125 + r * std::cos(a), y = 25 + r * std::sin(a), z = streetGround(x, y);
    w.cylinders.push_back({x, y, 0.25, z - 1, z + 3});
    w.cylinders.push_back({x, y, rng.uniform(1.8, 2.8), z + 3, z + rng.uniform(7, 10)});
  }
  for (int k = 0; k < 6; ++k) { // cars parked at an angle on the square's south side
    const double x = 106 + 7 * k + rng.uniform(-1, 1), y = -12.0, z = streetGround(x, y);
    orientedBox(w, {x, y, z + 0.55}, {2.2, 0.9, 0.45}, 60 * kDeg, 0.0, 0.0);
  }
  // Kerbside trees, lamps and parked cars along the ring road.
  streetFurniture(w, rng, streetGround, {0, -3}, {1, 0}, {0, -1}, 80);
  streetFurniture(w, rng, streetGround, {0, -17}, {1, 0}, {0, 1}, 90);
  streetFurniture(w, rng, streetGround, {0, 53}, {1, 0}, {0, 1}, 80);
  streetFurniture(w, rng, streetGround, {-10, 67}, {1, 0}, {0, -1}, 100);
  streetFurniture(w, rng, streetGround, {-3, 0}, {0, 1}, {-1, 0}, 50);
  streetFurniture(w, rng, streetGround, {-17, -5}, {0, 1}, {1, 0}, 60);
  streetFurniture(w, rng, streetGround, {83, 0}, {0, 1}, {1, 0}, 50);
  return w;
}

/** A hand-held scanner's turn off the route's heading at arc length s: yaw (looking
 *  around), pitch and roll (gait and hand), radians. */
using Attitude = std::function<Eigen::Vector3d(double s)>;

/**
 * A closed route: straight legs between waypoints (the last equal to the first),
 * corners rounded by two passes of a moving average `smoothing` metres wide; arc length
 * wraps round. Poses follow the ground: z along its normal, x along the heading; with an
 * attitude, z is up and the scanner turned by it from the heading instead.
 */
class Route {
public:
  Route(const std::vector<Eigen::Vector2d>& waypoints,
        double smoothing,
        Height ground,
        double sensor_height,
        Attitude attitude = nullptr)
      : ground_(std::move(ground))
      , sensor_height_(sensor_height)
      , attitude_(std::move(attitude))
  {
    const double ds = 0.05;
    std::vector<Eigen::Vector2d> p;
    waypoint_arc_.push_back(0.0);
    for (std::size_t k = 0; k + 1 < waypoints.size(); ++k) {
      const Eigen::Vector2d a = waypoints[k], b = waypoints[k + 1];
      const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / ds)));
      for (int i = 0; i < n; ++i) {
        p.push_back(a + (b - a) * (static_cast<double>(i) / n));
        waypoint_arc_.push_back(waypoint_arc_.back() + (b - a).norm() / n);
      }
    }
    const int n = static_cast<int>(p.size()), half = static_cast<int>(0.5 * smoothing / ds);
    for (int pass = 0; pass < 2 && half > 0; ++pass) { // cyclic moving average
      std::vector<Eigen::Vector2d> q(p.size(), Eigen::Vector2d::Zero());
      for (int i = 0; i < n; ++i) {
        for (int k = -half; k <= half; ++k)
          q[i] += p[static_cast<std::size_t>(((i + k) % n + n) % n)];
        q[i] /= 2 * half + 1;
      }
      p.swap(q);
    }
    points_ = p;
    arc_.assign(p.size() + 1, 0.0);
    for (int i = 0; i < n; ++i)
      arc_[i + 1] = arc_[i] + (p[(i + 1) % n] - p[i]).norm();
    heading_.resize(p.size());
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector2d d = p[(i + 1) % n] - p[(i + n - 1) % n];
      heading_[i] = std::atan2(d.y(), d.x());
    }
  }

  double
  length() const
  {
    return arc_.back();
  }

  /** The sensor pose at arc length s (any real: wraps round the loop). */
  Eigen::Matrix4d
  pose(double s) const
  {
    return pose(s, arc_);
  }

  /** The pose at distance u along the unrounded waypoint polyline: u at a corner gives
   *  the rounded corner's middle, where the heading is halfway through the turn. */
  Eigen::Matrix4d
  poseAtWaypointArc(double u) const
  {
    return pose(u, waypoint_arc_);
  }

  double
  waypointLength() const
  {
    return waypoint_arc_.back();
  }

private:
  Eigen::Matrix4d
  pose(double s, const std::vector<double>& arc) const
  {
    const std::size_t n = points_.size();
    // The carrier's attitude follows the distance walked, not its place on the loop:
    // wrapped, it would jump where a lap begins, tearing that sweep in two.
    const double walked = s;
    s = std::fmod(s, arc.back());
    if (s < 0)
      s += arc.back();
    const std::size_t i = std::min<std::size_t>(
        n - 1,
        static_cast<std::size_t>(std::upper_bound(arc.begin(), arc.end(), s) - arc.begin()) -
            1);
    const double f = (s - arc[i]) / std::max(1e-12, arc[i + 1] - arc[i]);
    const Eigen::Vector2d xy = points_[i] + f * (points_[(i + 1) % n] - points_[i]);
    double dh = heading_[(i + 1) % n] - heading_[i];
    dh = std::atan2(std::sin(dh), std::cos(dh));
    const double yaw = heading_[i] + f * dh;
    if (attitude_)
      return carried(xy, yaw, attitude_(walked));
    // The ground's normal from central differences; x: the heading in the tangent plane.
    const double e = 0.05, z = ground_(xy.x(), xy.y());
    const Eigen::Vector3d normal =
        Eigen::Vector3d(-(ground_(xy.x() + e, xy.y()) - ground_(xy.x() - e, xy.y())) / (2 * e),
                        -(ground_(xy.x(), xy.y() + e) - ground_(xy.x(), xy.y() - e)) / (2 * e),
                        1.0)
            .normalized();
    const Eigen::Vector3d forward(std::cos(yaw), std::sin(yaw), 0.0);
    const Eigen::Vector3d x = (forward - forward.dot(normal) * normal).normalized();
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.block<3, 1>(0, 0) = x;
    m.block<3, 1>(0, 1) = normal.cross(x);
    m.block<3, 1>(0, 2) = normal;
    m.block<3, 1>(0, 3) = Eigen::Vector3d(xy.x(), xy.y(), z) + sensor_height_ * normal;
    return m;
  }

  /** Held upright at sensor_height over the ground, turned by `a` from the heading. */
  Eigen::Matrix4d
  carried(const Eigen::Vector2d& xy, double yaw, const Eigen::Vector3d& a) const
  {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = eulerZYXToRotation(a[2], a[1], yaw + a[0]);
    m.block<3, 1>(0, 3) =
        Eigen::Vector3d(xy.x(), xy.y(), ground_(xy.x(), xy.y()) + sensor_height_);
    return m;
  }

  Height ground_;
  double sensor_height_;
  Attitude attitude_;
  std::vector<Eigen::Vector2d> points_;
  std::vector<double> arc_, waypoint_arc_, heading_; ///< arcs: one more than points_
};

Eigen::Matrix4d
yawStep(double dx, double dy, double yaw)
{
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  m(0, 3) = dx, m(1, 3) = dy;
  return m;
}

/** Everything a preset is made of. */
struct Spec {
  World world;
  ScannerModel scanner;
  std::vector<Eigen::Vector2d> waypoints;
  double smoothing = 1.0;
  Height ground = [](double, double) { return 0.0; };
  double sensor_height = 0.5;
  int scans = 0;
  double step = 0.0;   ///< metres between scans along the route
  double start = 0.0;  ///< arc length of scan 0
  double laps = 1.0;   ///< stop-and-go: scans spread over this many laps...
  double gap = 0.5;    ///< ...ending this many metres short of the start
  double period = 0.0; ///< seconds between scans
  /** While moving: the pace swings by this fraction of the mean over `pace_period`
   *  seconds (a walker's pace is not even); 0: a steady pace. */
  double pace_variation = 0.0, pace_period = 1.0;
  Attitude attitude; ///< a hand-held scanner's turns; none: it rides level on the route
  double translation_noise = 0.0, heading_noise = 0.0;
  std::string description;
};

ScannerModel
spherical(int columns,
          int rows,
          double min_el,
          double max_el,
          double min_range,
          double max_range,
          double noise)
{
  ScannerModel s;
  s.azimuth_steps = columns, s.elevation_steps = rows;
  s.min_elevation = min_el, s.max_elevation = max_el;
  s.min_range = min_range, s.max_range = max_range, s.range_noise = noise;
  return s;
}

/** A horizontal 2D scanner like the SICK LMS of the CARMEN logs: 180 beams 1 degree apart
 *  (-89.5 to +89.5 degrees), 80 m, 1 cm noise; its points lie in its x-y plane. */
ScannerModel
planarLaser()
{
  ScannerModel s;
  s.pattern = ScannerModel::Pattern::TiltingLine;
  s.azimuth_steps = 1, s.elevation_steps = 180, s.line_fov = 179 * kDeg;
  s.min_elevation = s.max_elevation = 0.0;
  s.min_range = 0.1, s.max_range = 80.0, s.range_noise = 0.01;
  return s;
}

const std::vector<std::string>&
names()
{
  static const std::vector<std::string> n{
      "office", "hannover", "riegl", "kitti", "office2d", "hannover2d", "handheld"};
  return n;
}

/** A 2D preset: a robot with planarLaser() 0.3 m above the floor drives a 3D preset's
 *  route (`where`), `scans` stops over one lap, its wheel odometry drifting 3 % of the
 *  distance and 0.02 rad per metre. */
Spec
planarSpec(Spec s, int scans, const std::string& where)
{
  s.scanner = planarLaser();
  s.sensor_height = 0.3;
  s.scans = scans, s.laps = 1.0, s.period = 1.0;
  s.translation_noise = 0.03, s.heading_noise = 0.02;
  s.description = std::to_string(scans) +
                  " scans x ~170 points, a horizontal 2D scanner (180 beams, 1 degree, 80 m) " +
                  where + " (paper Sec. VII)";
  return s;
}

Spec
makeSpec(const std::string& name, std::uint32_t seed)
{
  Spec s;
  if (name == "office") {
    s.world = officeWorld(seed);
    // Kurt3D: SICK LMS 181 beams over 180 degrees, pitched from -90 to +90 degrees.
    s.scanner.pattern = ScannerModel::Pattern::TiltingLine;
    s.scanner.azimuth_steps = 470, s.scanner.elevation_steps = 181;
    s.scanner.min_elevation = -90 * kDeg, s.scanner.max_elevation = 90 * kDeg;
    s.scanner.min_range = 0.3, s.scanner.max_range = 30.0, s.scanner.range_noise = 0.01;
    const Eigen::Vector2d a(2.0, 4.25), d = kOfficeLoop;
    s.waypoints = {a, a + Eigen::Vector2d(d.x(), 0), a + d, a + Eigen::Vector2d(0, d.y()), a};
    s.smoothing = 3.0, s.sensor_height = 0.5;
    s.scans = 11, s.period = 60.0, s.gap = 0.3;
    s.translation_noise = 0.03, s.heading_noise = 0.01;
    s.description = "11 scans x ~85k points, Kurt3D's tilting SICK, stop-and-go, one loop "
                    "on an office floor (paper Table I)";
  }
  else if (name == "hannover") {
    s.world = buildingWorld(seed);
    // A vertical 2D scanner turned about z: 181 beams x 112 turns.
    s.scanner = spherical(112, 181, -89 * kDeg, 89 * kDeg, 0.3, 30.0, 0.01);
    const auto node = [](int i, int j) {
      return Eigen::Vector2d(1.5 + 19.0 * i, 1.5 + 17.0 * j);
    };
    s.waypoints = {node(0, 0),
                   node(3, 0),
                   node(3, 2),
                   node(0, 2),
                   node(0, 0),
                   node(1, 0),
                   node(1, 2),
                   node(2, 2),
                   node(2, 1),
                   node(0, 1),
                   node(0, 0)};
    s.smoothing = 1.5, s.sensor_height = 0.8;
    s.scans = 468, s.period = 10.0, s.laps = 2.0, s.gap = 1.4;
    s.translation_noise = 0.02, s.heading_noise = 0.005;
    s.description = "468 scans x ~20k points, a rotating 2D scanner, stop-and-go, several "
                    "loops through a building's corridors (paper Sec. VI-C)";
  }
  else if (name == "riegl") {
    s.world = streetWorld(seed);
    s.scanner = spherical(1000, 550, -40 * kDeg, 60 * kDeg, 1.0, 200.0, 0.008);
    s.waypoints = {{105, -8}, {145, -8}, {145, 58}, {105, 58}, {105, -8}};
    s.smoothing = 6.0, s.ground = streetGround, s.sensor_height = 1.6;
    s.scans = 11, s.period = 600.0, s.gap = 2.0;
    s.translation_noise = 0.02, s.heading_noise = 0.003;
    s.description = "11 scans x ~300k points, a terrestrial scanner, stop-and-go, one loop "
                    "round a square over uneven ground (paper Table II)";
  }
  else if (name == "kitti") {
    s.world = streetWorld(seed);
    // HDL-64E-like: 64 beams from -24.8 to +2 degrees, 1900 columns, 10 Hz, while moving.
    s.scanner = spherical(1900, 64, -24.8 * kDeg, 2.0 * kDeg, 2.5, 120.0, 0.02);
    s.scanner.sweep_period = 0.1;
    s.waypoints = {{40, -10}, {90, -10}, {90, 60}, {-10, 60}, {-10, -10}, {40, -10}};
    s.smoothing = 12.0, s.ground = streetGround, s.sensor_height = 1.73;
    s.scans = 420, s.step = 0.9, s.period = 0.1; // 9 m/s
    s.translation_noise = 0.01, s.heading_noise = 0.001;
    s.description = "420 scans x ~120k points, a 64-beam lidar at 10 Hz scanning while "
                    "driving 9 m/s round a block over a ramp, closing the loop (KITTI-like)";
  }
  else if (name == "handheld") {
    s.world = splitLevelWorld(seed);
    // A 32-beam lidar (-30 to +30 degrees) spinning at 2 Hz, 2000 columns: 64k rays.
    s.scanner = spherical(2000, 32, -30 * kDeg, 30 * kDeg, 0.4, 50.0, 0.015);
    s.scanner.sweep_period = 0.5;
    // Round both wings, up the north stairs and down the south ones (x = 16..21).
    s.waypoints = {{3, 8}, {3, 13}, {34, 13}, {34, 3}, {3, 3}, {3, 8}};
    s.smoothing = 2.5, s.ground = splitLevelFloor, s.sensor_height = 1.5;
    s.scans = 130, s.step = 0.7, s.period = 0.5; // 1.4 m/s, 1.1 laps of 82 m
    s.pace_variation = 0.3, s.pace_period = 5.0; // 0.5 to 0.9 m a sweep
    Rng rng(seed * 0x100000001b3ull + 61);
    const double a = rng.uniform(0, 2 * M_PI), b = rng.uniform(0, 2 * M_PI),
                 c = rng.uniform(0, 2 * M_PI);
    s.attitude = [=](double u) { // looking round +-30 degrees, tilting +-8 and +-5
      return Eigen::Vector3d(30 * kDeg * std::sin(2 * M_PI * u / 8.0 + a),
                             8 * kDeg * std::sin(2 * M_PI * u / 4.3 + b),
                             5 * kDeg * std::sin(2 * M_PI * u / 2.9 + c));
    };
    s.translation_noise = 0.03, s.heading_noise = 0.02;
    s.description = "130 scans x ~64k points, a 32-beam lidar at 2 Hz carried by hand "
                    "through a split-level building, up and down its stairs, looking round "
                    "and tilting, 0.5-1.1 m and up to 60 degrees a sweep, closing the loop";
  }
  else if (name == "office2d") // a scan every 0.2 m
    s = planarSpec(makeSpec("office", seed), 150, "round the office floor's loop");
  else if (name == "hannover2d") // a scan every 0.4 m
    s = planarSpec(makeSpec("hannover", seed), 800, "through the building's corridors");
  else {
    std::string known;
    for (const auto& n : names())
      known += (known.empty() ? "" : ", ") + n;
    throw std::invalid_argument("[pcl_parallel::sim] unknown preset \"" + name +
                                "\"; known presets: " + known);
  }
  return s;
}

} // namespace

std::vector<std::string>
presetNames()
{
  return names();
}

std::string
presetDescription(const std::string& name)
{
  return makeSpec(name, 1).description; // throws on an unknown name, listing the known
}

SimulatedScanSet
simulatePreset(const std::string& name, std::uint32_t seed, unsigned num_threads)
{
  PresetOptions o;
  o.seed = seed;
  o.num_threads = num_threads;
  return simulatePreset(name, o);
}

namespace {

/** The options' overrides of the preset's odometry noise and beam count, checked. */
void
applyOptions(Spec& spec, const PresetOptions& o)
{
  if (o.odometry_translation_noise >= 0.0)
    spec.translation_noise = o.odometry_translation_noise;
  if (o.odometry_heading_noise >= 0.0)
    spec.heading_noise = o.odometry_heading_noise;
  if (!std::isfinite(spec.translation_noise) || !std::isfinite(spec.heading_noise))
    throw std::invalid_argument("[pcl_parallel::sim] odometry noise must be finite");
  if (o.beams < 0 || o.beams == 1 || o.beams > 4096) // 64x a Velodyne HDL-64E's rows
    throw std::invalid_argument("[pcl_parallel::sim] beams must be 0 (the preset's) or 2 to "
                                "4096, got " +
                                std::to_string(o.beams));
  if (o.beams > 0)
    spec.scanner.elevation_steps = o.beams;
  validate(spec.scanner);
}

/** Odometry: the true step, disturbed in the plane of the vehicle, accumulated. */
void
addOdometry(SimulatedScanSet& set, const Spec& spec, std::uint32_t seed)
{
  const int n = static_cast<int>(set.truth.size());
  Rng rng(0x6f646f6dull ^ (static_cast<std::uint64_t>(seed) << 20));
  if (n > 0)
    set.odometry.push_back(set.truth[0]);
  for (int i = 1; i < n; ++i) {
    const Eigen::Matrix4d step = set.truth[i - 1].inverse() * set.truth[i];
    const double l = step.topRightCorner<3, 1>().norm();
    const double ex = spec.translation_noise * l * rng.normal(),
                 ey = spec.translation_noise * l * rng.normal(),
                 eyaw = spec.heading_noise * l * rng.normal();
    set.odometry.push_back(set.odometry.back() * step * yawStep(ex, ey, eyaw));
  }
}

/** The scans at the set's poses (while moving: each column from the route's pose at its
 *  sweep time, the vehicle at `speed` m/s), each from its own key. */
void
castScans(SimulatedScanSet& set,
          const Spec& spec,
          const Route& route,
          const PresetOptions& o,
          const std::function<double(int, double)>& arc)
{
  const int n = static_cast<int>(set.truth.size());
  const bool moving = spec.scanner.sweep_period > 0.0;
  const RayCaster caster(spec.world);
  set.scans.resize(static_cast<std::size_t>(n));
  if (moving)
    set.point_times.resize(static_cast<std::size_t>(n));
  const auto scan = [&](int i, unsigned threads) {
    const auto k = static_cast<std::size_t>(i);
    const std::uint64_t key =
        scanKey(o.seed, k * static_cast<std::size_t>(o.stride)); // keyed as without stride
    if (moving) {
      // Column c at sweep time t_c, i.e. (t_c - 0.5) * period after the reference pose.
      const double cols = spec.scanner.azimuth_steps;
      const auto pose = [&](int c) { return route.pose(arc(i, (c + 0.5) / cols - 0.5)); };
      set.scans[k] = castScan(caster, spec.scanner, pose, key, threads, &set.point_times[k]);
    }
    else
      set.scans[k] = castScan(caster, spec.scanner, set.truth[k], key, threads);
  };
  // Many scans: one per thread (a parallel region per scan costs a barrier each, which
  // hurts on a loaded machine); few: the rays of each scan in parallel. Either way a
  // scan depends on its key alone. Batches keep the progress calls on this thread.
  const unsigned threads = resolveNumberOfThreads(o.num_threads);
  const bool per_scan = threads > 1 && n >= 4 * static_cast<int>(threads);
  const int batch = per_scan ? 8 * static_cast<int>(threads) : 1;
  for (int first = 0; first < n; first += batch) {
    const int last = std::min(n, first + batch);
    parallelFor(static_cast<std::size_t>(last - first),
                per_scan ? threads : 1,
                1,
                [&](std::size_t i0, std::size_t i1) {
                  for (std::size_t i = i0; i < i1; ++i)
                    scan(first + static_cast<int>(i), per_scan ? 1u : threads);
                });
    if (o.progress)
      o.progress(last, n);
  }
}

} // namespace

SimulatedScanSet
simulatePreset(const std::string& name, const PresetOptions& o)
{
  Spec spec = makeSpec(name, o.seed);
  applyOptions(spec, o);
  const Route route(
      spec.waypoints, spec.smoothing, spec.ground, spec.sensor_height, spec.attitude);
  // Stop-and-go: scans spread over the laps of the waypoint polyline (so that a side
  // of k steps puts stops at its corners), the last one `gap` short of the start.
  const bool moving = spec.scanner.sweep_period > 0.0;
  if (!moving)
    spec.step = (spec.laps * route.waypointLength() - spec.gap) / std::max(1, spec.scans - 1);
  if (o.stride < 1)
    throw std::invalid_argument("[pcl_parallel::sim] stride must be >= 1, got " +
                                std::to_string(o.stride));
  const double speed = spec.step / spec.period; // metres per second along the route
  spec.step *= o.stride;                        // between kept scans
  // While moving: the arc length `f` sweeps after kept scan i's time.
  const auto arc = [&](int i, double f) {
    const double sweep = spec.scanner.sweep_period, w = 2 * M_PI / spec.pace_period;
    const double t = static_cast<double>(i) * o.stride * spec.period + f * sweep;
    const double swing =
        spec.pace_variation == 0.0 ? 0.0 : spec.pace_variation * speed / w * std::sin(w * t);
    return spec.start + i * spec.step + speed * f * sweep + swing;
  };
  const int kept = (spec.scans + o.stride - 1) / o.stride;
  const int n = o.max_scans >= 0 ? std::min(o.max_scans, kept) : kept;

  SimulatedScanSet set;
  set.name = name;
  set.scanner = spec.scanner;
  for (int i = 0; i < n; ++i) {
    const double s = spec.start + i * spec.step;
    set.truth.push_back(moving ? route.pose(arc(i, 0.0)) : route.poseAtWaypointArc(s));
    // 0.3, not 3 * 0.1 = 0.30000000000000004
    set.timestamps.push_back(static_cast<double>(i) * o.stride / (1.0 / spec.period));
  }
  addOdometry(set, spec, o.seed);
  if (o.poses_only) {
    set.scans.assign(static_cast<std::size_t>(n), nullptr);
    for (auto& scan : set.scans)
      scan.reset(new pcl::PointCloud<pcl::PointXYZ>);
    if (moving)
      set.point_times.resize(static_cast<std::size_t>(n));
  }
  else
    castScans(set, spec, route, o, arc);
  set.world = std::move(spec.world);
  return set;
}

} // namespace sim
} // namespace pcl_parallel
