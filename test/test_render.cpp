/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * render/: the map's picture (its extent, its style, the PNG file, the occupancy of 2D
 * scans read back pixel by pixel).
 */
#include <pcl_parallel/render/map_picture.h>

#include <Eigen/Core>

#include <cairo.h>
#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <iterator>
#include <memory>
#include <random>
#include <stdexcept>
#include <string>
#include <unistd.h>
#include <vector>

namespace fs = std::filesystem;
namespace render = pcl_parallel::render;

namespace {

fs::path
scratch(const std::string& name)
{
  const fs::path p = fs::temp_directory_path() /
                     ("pcl_parallel_render_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

} // namespace

// The picture's extent covers the trajectory and the points around it, and neither one
// far return nor a sprinkle of them (min/max would take them all in) moves it.
TEST(MapPicture, ExtentIsRobustToFarReturns)
{
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> room(-5.0, 25.0);
  std::vector<Eigen::Vector2d> trajectory, points;
  for (int i = 0; i <= 20; ++i)
    trajectory.emplace_back(i, 0.5 * i); // (0,0) -> (20,10)
  for (int i = 0; i < 20000; ++i)
    points.emplace_back(room(rng), room(rng) - 10.0);
  const auto base = render::robustExtent(points, trajectory);
  auto covers = [](const render::Extent& e, const Eigen::Vector2d& p) {
    return p.x() >= e.lo.x() && p.y() >= e.lo.y() && p.x() <= e.hi.x() && p.y() <= e.hi.y();
  };
  for (const auto& t : trajectory)
    EXPECT_TRUE(covers(base, t));
  // The room: [-5, 25] x [-15, 15], its extent within a margin of that.
  EXPECT_NEAR(base.lo.x(), -5.0, 2.5);
  EXPECT_NEAR(base.hi.x(), 25.0, 2.5);
  EXPECT_NEAR(base.lo.y(), -15.0, 2.5);
  EXPECT_NEAR(base.hi.y(), 15.0, 2.5);

  auto with_one = points;
  with_one.emplace_back(3000.0, -5000.0);
  const auto one = render::robustExtent(with_one, trajectory);
  EXPECT_LT((one.lo - base.lo).norm() + (one.hi - base.hi).norm(), 1e-3);

  auto with_many = points; // 0.4% far returns in every direction, some within the radius
  std::uniform_real_distribution<double> far(-2000.0, 2000.0);
  for (int i = 0; i < 80; ++i)
    with_many.emplace_back(far(rng), far(rng));
  for (int i = 0; i < 20; ++i) // just inside the 30 m radius, all on one side
    with_many.emplace_back(10.0 + 0.1 * i, 38.0);
  const auto many = render::robustExtent(with_many, trajectory);
  EXPECT_LT((many.hi - base.hi).cwiseAbs().maxCoeff(), 1.0);
  EXPECT_LT((many.lo - base.lo).cwiseAbs().maxCoeff(), 1.0);

  // No points at all: the trajectory (with margin) still gives a picture.
  const auto bare = render::robustExtent({}, trajectory);
  for (const auto& t : trajectory)
    EXPECT_TRUE(covers(bare, t));
}

// A room (floor, ceiling, walls) reads as a floor plan; open ground with a few trees as a
// height map; both pictures are PNGs at least as wide as the caption needs.
TEST(MapPicture, StyleAndFile)
{
  render::Cloud room, field;
  for (double x = -5; x <= 5; x += 0.1)
    for (double y = -4; y <= 4; y += 0.1) {
      room.emplace_back(x, y, -1.0f); // floor 1 m below the scanner, ceiling 1.5 m above
      room.emplace_back(x, y, 1.5f);
      field.emplace_back(x * 4, y * 4, -1.8f);
    }
  for (double z = -1; z <= 1.5; z += 0.1)
    for (double t = -4; t <= 4; t += 0.1) {
      room.emplace_back(-5.0f, t, z), room.emplace_back(5.0f, t, z);
      field.emplace_back(8.0f, 6.0f + 0.1 * t, z + 1.0); // a tree trunk
    }
  render::Poses path;
  for (int i = 0; i < 8; ++i) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m(0, 3) = -3.5 + i;
    path.push_back(m);
  }
  EXPECT_EQ(render::chooseStyle(room, path, 2), "floorplan");
  EXPECT_EQ(render::chooseStyle(field, path, 2), "height");
  const fs::path dir = scratch("picture");
  render::PictureOptions po;
  po.caption = {"test"};
  po.loops = {{0, 7}};
  for (const auto* cloud : {&room, &field}) {
    const std::string path_png = (dir / "map.png").string();
    const std::string style = render::writeMapPicture(path_png, *cloud, path, po);
    EXPECT_EQ(style, cloud == &room ? "floorplan" : "height");
    std::ifstream in(path_png, std::ios::binary);
    char magic[8] = {};
    in.read(magic, 8);
    EXPECT_EQ(std::string(magic + 1, 3), "PNG");
  }
  // Written under a temporary name and renamed: nothing else is left, and a file that
  // cannot be written is an error naming it, not its temporary.
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  const std::string missing = (dir / "no_such_dir" / "map.png").string();
  try {
    render::writeMapPicture(missing, room, path, po);
    ADD_FAILURE() << "no error";
  }
  catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find(missing + ": "), 0u) << what;
    EXPECT_EQ(what.find(".tmp"), std::string::npos) << what;
  }
  fs::remove_all(dir);
}

// The occupancy style of 2D scans: a square room scanned from inside, four poses. Its
// walls are dark, the free space inside white, the margin outside (no ray reached it)
// grey; the style needs a scan per pose.
TEST(MapPicture, OccupancyOfTwoDScansFromTheirRays)
{
  render::Cloud scan; // a 10 m x 10 m room's walls, seen from (0, 0) in 720 beams
  for (int b = 0; b < 720; ++b) {
    const double a = b * M_PI / 360.0, c = std::cos(a), s = std::sin(a);
    const double range = 5.0 / std::max(std::abs(c), std::abs(s));
    scan.emplace_back(range * c, range * s, 0.0f);
  }
  render::Poses path(4, Eigen::Matrix4d::Identity());
  render::Cloud map;
  std::vector<render::Cloud::ConstPtr> scans;
  for (int i = 0; i < 4; ++i) { // the poses 0.5 m apart along x, each scan in its frame
    path[i](0, 3) = -0.75 + 0.5 * i;
    render::Cloud::Ptr local(new render::Cloud(scan));
    for (auto& p : *local)
      p.x -= static_cast<float>(path[i](0, 3)); // the walls stay where they are
    scans.push_back(local);
  }
  for (const auto& p : scan)
    map.push_back(p);
  const fs::path dir = scratch("occupancy");
  const std::string png = (dir / "map.png").string();
  render::PictureOptions po;
  po.cell = 0.05;
  EXPECT_THROW(render::writeMapPicture(png,
                                       map,
                                       path,
                                       [&] {
                                         render::PictureOptions o = po;
                                         o.style = "occupancy";
                                         return o;
                                       }()),
               std::invalid_argument);
  po.scans = scans;
  ASSERT_EQ(render::writeMapPicture(png, map, path, po), "occupancy");
  // The pixel of (x, y) as writeMapPicture frames the map (robustExtent, 20 px padding).
  std::vector<Eigen::Vector2d> points, trajectory;
  for (const auto& p : map)
    points.emplace_back(p.x, p.y);
  for (const auto& m : path)
    trajectory.emplace_back(m(0, 3), m(1, 3));
  const render::Extent e = render::robustExtent(points, trajectory, po.radius);
  const double scale = po.size / (e.hi - e.lo).maxCoeff();
  std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)> image(
      cairo_image_surface_create_from_png(png.c_str()), cairo_surface_destroy);
  ASSERT_EQ(cairo_surface_status(image.get()), CAIRO_STATUS_SUCCESS);
  const unsigned char* data = cairo_image_surface_get_data(image.get());
  const int stride = cairo_image_surface_get_stride(image.get());
  const auto grey = [&](double x, double y) { // the green channel, 0-255
    const int px = static_cast<int>(20 + (x - e.lo.x()) * scale),
              py = static_cast<int>(20 + (e.hi.y() - y) * scale);
    const auto* row = reinterpret_cast<const std::uint32_t*>(data + py * stride);
    return static_cast<int>((row[px] >> 8) & 0xff);
  };
  for (const auto& [x, y] : {std::pair{2.5, 2.5}, {-2.5, -3.0}, {0.0, 3.5}, {3.5, -1.0}})
    EXPECT_EQ(grey(x, y), 255) << x << " " << y; // free: every ray passed
  for (const auto& [x, y] : {std::pair{5.0, 2.02}, {-5.0, -1.02}, {1.52, 5.0}, {-1.02, -5.0}})
    EXPECT_LT(grey(x, y), 128) << x << " " << y; // a wall: most rays reaching it ended there
  for (const auto& [x, y] : {std::pair{5.3, 0.0}, {-5.3, 2.0}, {0.0, -5.3}})
    EXPECT_EQ(grey(x, y), static_cast<int>(0.76 * 255)) << x << " " << y; // unseen
  fs::remove_all(dir);
}
