/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/io/atomic_write.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/render/map_picture.h>

#include <algorithm>
#include <array>
#include <cairo.h>
#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <unordered_map>

namespace pcl_parallel {
namespace render {

namespace {

/** Trajectory positions thinned to one per `thin` metre cell, in a hash grid of cell
 *  `radius`: the nearest one to a point within `radius` in a 3x3 cell look-up. A scanner
 *  turned in place (hundreds of poses in one spot) costs one position. */
class TrajectoryIndex {
public:
  TrajectoryIndex(const std::vector<Eigen::Vector2d>& trajectory, double radius, double thin)
      : radius_(radius)
  {
    std::unordered_map<std::int64_t, int> taken;
    for (std::size_t i = 0; i < trajectory.size(); ++i) {
      const Eigen::Vector2d& t = trajectory[i];
      if (!t.allFinite())
        continue;
      if (!taken.emplace(key(t, thin), static_cast<int>(i)).second)
        continue;
      grid_[key(t, radius_)].push_back(static_cast<int>(kept_.size()));
      kept_.push_back(t);
      pose_.push_back(static_cast<int>(i));
    }
  }

  /** The trajectory index of the nearest kept position within radius, -1 if none. */
  int
  nearest(const Eigen::Vector2d& p, double* distance = nullptr) const
  {
    const auto cx = static_cast<std::int64_t>(std::floor(p.x() / radius_));
    const auto cy = static_cast<std::int64_t>(std::floor(p.y() / radius_));
    double best = radius_ * radius_;
    int found = -1;
    for (std::int64_t dx = -1; dx <= 1; ++dx)
      for (std::int64_t dy = -1; dy <= 1; ++dy) {
        const auto it = grid_.find(pack(cx + dx, cy + dy));
        if (it == grid_.end())
          continue;
        for (int k : it->second) {
          const double d = (kept_[k] - p).squaredNorm();
          if (d <= best)
            best = d, found = k;
        }
      }
    if (distance)
      *distance = std::sqrt(best);
    return found < 0 ? -1 : pose_[found];
  }

private:
  static std::int64_t
  pack(std::int64_t x, std::int64_t y)
  {
    // Shifted unsigned: a negative cell index shifted left is undefined before C++20.
    return static_cast<std::int64_t>((static_cast<std::uint64_t>(x) << 32) ^
                                     (static_cast<std::uint64_t>(y) & 0xffffffffu));
  }
  static std::int64_t
  key(const Eigen::Vector2d& p, double cell)
  {
    return pack(static_cast<std::int64_t>(std::floor(p.x() / cell)),
                static_cast<std::int64_t>(std::floor(p.y() / cell)));
  }

  double radius_;
  std::vector<Eigen::Vector2d> kept_;
  std::vector<int> pose_;
  std::unordered_map<std::int64_t, std::vector<int>> grid_;
};

/** The q-quantile of v (nth_element; v is reordered). */
double
quantile(std::vector<double>& v, double q)
{
  const auto k = static_cast<std::size_t>(std::clamp(q, 0.0, 1.0) * (v.size() - 1) + 0.5);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

/** Light (low) to dark red (high): the ground stays light, what stands on it shows. */
std::array<double, 3>
heightColour(double t)
{
  static const double stops[][4] = {{0.0, 0.86, 0.88, 0.92},
                                    {0.3, 0.47, 0.75, 0.47},
                                    {0.65, 0.94, 0.67, 0.24},
                                    {1.0, 0.59, 0.12, 0.12}};
  t = std::clamp(t, 0.0, 1.0);
  int k = 0;
  while (k < 2 && t > stops[k + 1][0])
    ++k;
  const double f = (t - stops[k][0]) / (stops[k + 1][0] - stops[k][0]);
  return {stops[k][1] + f * (stops[k + 1][1] - stops[k][1]),
          stops[k][2] + f * (stops[k + 1][2] - stops[k][2]),
          stops[k][3] + f * (stops[k + 1][3] - stops[k][3])};
}

/** A "nice" length (1, 2 or 5 times a power of ten) not above x. */
double
niceLength(double x)
{
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {5.0, 2.0, 1.0})
    if (m * p <= x)
      return m * p;
  return p;
}

std::string
formatLength(double m)
{
  char s[32];
  if (m >= 1000.0)
    std::snprintf(s, sizeof s, "%g km", m / 1000.0);
  else if (m >= 1.0)
    std::snprintf(s, sizeof s, "%g m", m);
  else
    std::snprintf(s, sizeof s, "%g cm", m * 100.0);
  return s;
}

/** The plane of the top view: image right = axis u, image up = axis v (negated for a
 *  left-handed frame such as 3DTK's, so the picture is not mirrored). */
struct View {
  int up, u, v;
  double flip;
  Eigen::Vector2d
  operator()(const float* p) const
  {
    return {p[u], flip * p[v]};
  }
  Eigen::Vector2d
  operator()(const Eigen::Matrix4d& m) const
  {
    return {m(u, 3), flip * m(v, 3)};
  }
};

View
makeView(int up)
{
  // 3DTK's frame (y up) is left-handed: x right, z forward seen from above is x = -v.
  if (up == 1)
    return View{1, 2, 0, -1.0};
  return View{up, (up + 1) % 3, (up + 2) % 3, 1.0};
}

/** `text` broken at spaces into lines at most `width` wide in cr's font; a word wider
 *  than that stays whole on its own line. */
std::vector<std::string>
wrapText(cairo_t* cr, const std::string& text, double width)
{
  std::vector<std::string> out;
  std::string line;
  for (std::size_t pos = 0; pos <= text.size();) {
    const std::size_t end = std::min(text.find(' ', pos), text.size());
    const std::string word = text.substr(pos, end - pos);
    const std::string longer = line.empty() ? word : line + " " + word;
    cairo_text_extents_t ext;
    cairo_text_extents(cr, longer.c_str(), &ext);
    if (!line.empty() && ext.x_advance > width) {
      out.push_back(line);
      line = word;
    }
    else
      line = longer;
    pos = end + 1;
  }
  if (!line.empty())
    out.push_back(line);
  return out;
}

/** The caption's font, the same for measuring and drawing. */
void
captionFont(cairo_t* cr)
{
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, 14);
}

} // namespace

Extent
robustExtent(const std::vector<Eigen::Vector2d>& points,
             const std::vector<Eigen::Vector2d>& trajectory,
             double radius,
             double q,
             double margin)
{
  if (trajectory.empty())
    throw std::invalid_argument("robustExtent: empty trajectory");
  Extent e{Eigen::Vector2d::Constant(1e300), Eigen::Vector2d::Constant(-1e300)};
  for (const auto& t : trajectory)
    if (t.allFinite())
      e.lo = e.lo.cwiseMin(t), e.hi = e.hi.cwiseMax(t);
  const TrajectoryIndex index(trajectory, radius, radius / 20.0);
  std::vector<double> xs, ys;
  for (const auto& p : points)
    if (p.allFinite() && index.nearest(p) >= 0)
      xs.push_back(p.x()), ys.push_back(p.y());
  if (!xs.empty()) {
    e.lo = e.lo.cwiseMin(Eigen::Vector2d(quantile(xs, q), quantile(ys, q)));
    e.hi = e.hi.cwiseMax(Eigen::Vector2d(quantile(xs, 1.0 - q), quantile(ys, 1.0 - q)));
  }
  // At least a metre across, then the margin on every side.
  const Eigen::Vector2d centre = 0.5 * (e.lo + e.hi);
  const Eigen::Vector2d half = (0.5 * (e.hi - e.lo)).cwiseMax(Eigen::Vector2d(0.5, 0.5));
  const double grow = margin * 2.0 * half.maxCoeff();
  e.lo = centre - half - Eigen::Vector2d::Constant(grow);
  e.hi = centre + half + Eigen::Vector2d::Constant(grow);
  return e;
}

std::string
chooseStyle(const Cloud& map, const Poses& trajectory, int up, unsigned num_threads)
{
  const View view = makeView(up);
  std::vector<Eigen::Vector2d> traj;
  for (const auto& t : trajectory)
    traj.push_back(view(t));
  const TrajectoryIndex index(traj, 1.0, 0.25);
  // Each point's trajectory position in parallel (millions of map points), counted after.
  std::vector<int> nearest(map.size());
  const std::size_t n = map.size();
  const unsigned threads = n > 100000 ? pcl_parallel::resolveNumberOfThreads(num_threads) : 1;
  pcl_parallel::parallelFor(n,
                            threads,
                            pcl_parallel::evenGrain(n, threads),
                            [&](std::size_t first, std::size_t last) {
                              for (std::size_t i = first; i < last; ++i)
                                nearest[i] = index.nearest(view(map[i].data));
                            });
  std::vector<int> ceiling(trajectory.size(), 0);
  for (std::size_t i = 0; i < map.size(); ++i) {
    const int k = nearest[i];
    if (k < 0)
      continue;
    const double above = map[i].data[up] - trajectory[k](up, 3);
    if (above > 0.3 && above < 6.0)
      ++ceiling[k];
  }
  // Count over the thinned positions (those nearest() can return).
  std::size_t seen = 0, all = 0;
  for (std::size_t i = 0; i < traj.size(); ++i)
    if (index.nearest(traj[i]) == static_cast<int>(i))
      ++all, seen += ceiling[i] >= 20 ? 1 : 0; // a patch of surface, not a stray point
  return all > 0 && 2 * seen > all ? "floorplan" : "height";
}

std::string
cairoVersion()
{
  return cairo_version_string();
}

namespace {

/** View coordinates to pixels of the map area (y down). */
struct PixelFrame {
  Eigen::Vector2d lo, hi;
  double scale = 1.0; ///< pixels per metre
  Eigen::Vector2d
  operator()(const Eigen::Vector2d& p) const
  {
    return Eigen::Vector2d((p.x() - lo.x()) * scale, (hi.y() - p.y()) * scale);
  }
};

/** The map from above in cells of the map's voxel (at least a pixel, so a sparse reduced
 *  map reads as surfaces rather than dots). Per cell the highest point, and for floor
 *  plans the heights between floor and ceiling; heights are above the nearest trajectory
 *  position, so the ground along a slope or ramp keeps one colour. */
struct HeightGrid {
  int width = 0, height = 0; ///< cells
  double cell_px = 1.0;
  std::vector<float> top, band_lo, band_hi;
  double lo = -2.0, hi = 4.0; ///< colour scale: 2 % and 98 % of the cells' tops
  bool
  empty(std::size_t c) const
  {
    return top[c] < -1e29f;
  }
};

HeightGrid
heightGrid(const Cloud& map,
           const Poses& trajectory,
           const std::vector<Eigen::Vector2d>& traj,
           const View& view,
           const PixelFrame& px,
           int w,
           int h,
           const std::string& style,
           const PictureOptions& opt)
{
  HeightGrid g;
  const TrajectoryIndex index(traj, opt.radius, opt.radius / 20.0);
  g.cell_px = std::max(1.0, opt.cell * px.scale);
  g.width = static_cast<int>(std::ceil(w / g.cell_px));
  g.height = static_cast<int>(std::ceil(h / g.cell_px));
  const std::size_t cells = static_cast<std::size_t>(g.width) * g.height;
  g.top.assign(cells, -1e30f);
  g.band_lo.assign(cells, 1e30f);
  g.band_hi.assign(cells, -1e30f);
  std::vector<float> rel(map.size());
  std::vector<std::int64_t> cell_of(map.size(), -1);
  const std::size_t n = map.size();
  const unsigned threads =
      n > 100000 ? pcl_parallel::resolveNumberOfThreads(opt.num_threads) : 1;
  pcl_parallel::parallelFor(
      n,
      threads,
      pcl_parallel::evenGrain(n, threads),
      [&](std::size_t first, std::size_t last) {
        for (std::size_t i = first; i < last; ++i) {
          const Eigen::Vector2d q = view(map[i].data);
          const Eigen::Vector2d xy = px(q) / g.cell_px;
          if (!(xy.x() >= 0 && xy.y() >= 0 && xy.x() < g.width && xy.y() < g.height))
            continue;
          const int k = index.nearest(q);
          rel[i] = static_cast<float>(map[i].data[opt.up] -
                                      (k >= 0 ? trajectory[k](opt.up, 3) : 0.0));
          cell_of[i] =
              static_cast<std::int64_t>(xy.y()) * g.width + static_cast<std::int64_t>(xy.x());
        }
      });
  // Floor plan, per cell: the lowest and highest points are floor and ceiling (or a table
  // top); points between them, over 25 cm of height, are a wall or an object. Per cell,
  // so a world frame that is not level (a handheld scanner's first pose) does not turn a
  // tilted floor into walls.
  std::vector<float> bottom(cells, 1e30f);
  for (std::size_t i = 0; i < map.size(); ++i) {
    if (cell_of[i] < 0)
      continue;
    const auto c = static_cast<std::size_t>(cell_of[i]);
    g.top[c] = std::max(g.top[c], rel[i]);
    bottom[c] = std::min(bottom[c], rel[i]);
  }
  if (style == "floorplan")
    for (std::size_t i = 0; i < map.size(); ++i) {
      if (cell_of[i] < 0)
        continue;
      const auto c = static_cast<std::size_t>(cell_of[i]);
      if (rel[i] > bottom[c] + 0.15f && rel[i] < g.top[c] - 0.15f)
        g.band_lo[c] = std::min(g.band_lo[c], rel[i]),
        g.band_hi[c] = std::max(g.band_hi[c], rel[i]);
    }
  std::vector<double> tops;
  for (std::size_t c = 0; c < cells; ++c)
    if (!g.empty(c))
      tops.push_back(g.top[c]);
  if (tops.size() > 10) {
    g.lo = quantile(tops, 0.02);
    g.hi = std::max(quantile(tops, 0.98), g.lo + 0.5);
  }
  return g;
}

/** The occupancy style's grid (2D scans): per cell, of the rays from each pose to its
 *  scan's points that reach the cell, the share ending there (`top`, in [0, 1]); cells no
 *  ray reaches stay empty. Rays are walked in half-cell steps, in scan order. */
HeightGrid
occupancyGrid(const Poses& trajectory,
              const View& view,
              const PixelFrame& px,
              int w,
              int h,
              const PictureOptions& opt)
{
  HeightGrid g;
  g.cell_px = std::max(1.0, opt.cell * px.scale);
  g.width = static_cast<int>(std::ceil(w / g.cell_px));
  g.height = static_cast<int>(std::ceil(h / g.cell_px));
  const std::size_t cells = static_cast<std::size_t>(g.width) * g.height;
  std::vector<std::uint32_t> hits(cells, 0), visits(cells, 0);
  const auto cellOf = [&](const Eigen::Vector2d& c) -> std::int64_t {
    if (!(c.x() >= 0 && c.y() >= 0 && c.x() < g.width && c.y() < g.height))
      return -1;
    return static_cast<std::int64_t>(c.y()) * g.width + static_cast<std::int64_t>(c.x());
  };
  for (std::size_t k = 0; k < trajectory.size(); ++k) {
    if (!opt.scans[k])
      continue;
    const Eigen::Matrix4f pose = trajectory[k].cast<float>();
    const Eigen::Vector2d from = px(view(trajectory[k])) / g.cell_px;
    for (const auto& p : *opt.scans[k]) {
      const Eigen::Vector3f q =
          pose.topLeftCorner<3, 3>() * p.getVector3fMap() + pose.topRightCorner<3, 1>();
      const Eigen::Vector2d to = px(view(q.data())) / g.cell_px, d = to - from;
      const std::int64_t end = cellOf(to);
      const int steps = std::max(1, static_cast<int>(std::ceil(2.0 * d.norm())));
      for (std::int64_t s = 0, last = -1; s < steps; ++s) {
        const std::int64_t c = cellOf(from + d * (static_cast<double>(s) / steps));
        if (c >= 0 && c != last && c != end)
          ++visits[static_cast<std::size_t>(c)];
        last = c;
      }
      if (end >= 0)
        ++hits[static_cast<std::size_t>(end)], ++visits[static_cast<std::size_t>(end)];
    }
  }
  g.top.assign(cells, -1e30f);
  for (std::size_t c = 0; c < cells; ++c)
    if (visits[c] > 0)
      g.top[c] = static_cast<float>(hits[c]) / static_cast<float>(visits[c]);
  return g;
}

/** Paints the canvas white and the grid's cells into the map area (w x h at pad). */
void
paintGrid(cairo_surface_t* surface,
          const HeightGrid& g,
          const std::string& style,
          int w,
          int h,
          int pad)
{
  cairo_surface_flush(surface);
  unsigned char* data = cairo_image_surface_get_data(surface);
  const int stride_bytes = cairo_image_surface_get_stride(surface);
  auto put = [&](int x, int y, double r, double gr, double b) {
    auto* row =
        reinterpret_cast<std::uint32_t*>(data + static_cast<std::size_t>(y) * stride_bytes);
    row[x] = (static_cast<std::uint32_t>(r * 255) << 16) |
             (static_cast<std::uint32_t>(gr * 255) << 8) | static_cast<std::uint32_t>(b * 255);
  };
  const int W = cairo_image_surface_get_width(surface),
            H = cairo_image_surface_get_height(surface);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      put(x, y, 1, 1, 1);
  if (style == "occupancy") // unknown: grey
    for (int y = pad; y < pad + h; ++y)
      for (int x = pad; x < pad + w; ++x)
        put(x, y, 0.74, 0.76, 0.8);
  for (int gy = 0; gy < g.height; ++gy)
    for (int gx = 0; gx < g.width; ++gx) {
      const std::size_t c = static_cast<std::size_t>(gy) * g.width + gx;
      if (g.empty(c))
        continue;
      std::array<double, 3> col;
      if (style == "floorplan") {
        // A wall or an object stands between floor and ceiling, over some height; a
        // sloping or noisy floor does not.
        const double grey = g.band_hi[c] - g.band_lo[c] >= 0.25 ? 0.25 : 0.84;
        col = {grey, grey, grey};
      }
      else if (style == "occupancy") { // free white; a cell hit by 40 % of its rays black
        const double grey = 1.0 - std::min(1.0, g.top[c] / 0.4);
        col = {grey, grey, grey};
      }
      else
        col = heightColour((g.top[c] - g.lo) / (g.hi - g.lo));
      const int x0 = static_cast<int>(gx * g.cell_px),
                x1 = std::min(w, static_cast<int>((gx + 1) * g.cell_px));
      const int y0 = static_cast<int>(gy * g.cell_px),
                y1 = std::min(h, static_cast<int>((gy + 1) * g.cell_px));
      for (int y = y0; y < std::max(y1, y0 + 1); ++y)
        for (int x = x0; x < std::max(x1, x0 + 1); ++x)
          put(x + pad, y + pad, col[0], col[1], col[2]);
    }
  cairo_surface_mark_dirty(surface);
}

/** Loop links (blue dashes), the trajectory (a dark line on a white halo), its start (a
 *  green disc) and end (a black ring), at canvas positions `at`. */
void
drawTrajectory(cairo_t* cr,
               const std::vector<Eigen::Vector2d>& at,
               const std::vector<std::pair<std::uint32_t, std::uint32_t>>& loops,
               const std::string& style)
{
  const double dash[] = {6.0, 4.0};
  cairo_set_dash(cr, dash, 2, 0);
  cairo_set_line_width(cr, 1.2);
  // Many links (a scanner turned in one room) fade, so the trajectory stays visible.
  const double alpha = std::clamp(40.0 / std::max<double>(1.0, loops.size()), 0.1, 0.8);
  cairo_set_source_rgba(cr, 0.0, 0.35, 1.0, alpha);
  for (const auto& [a, b] : loops) {
    if (a >= at.size() || b >= at.size())
      continue;
    cairo_move_to(cr, at[a].x(), at[a].y());
    cairo_line_to(cr, at[b].x(), at[b].y());
  }
  cairo_stroke(cr);
  cairo_set_dash(cr, nullptr, 0, 0);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  for (int pass = 0; pass < 2; ++pass) {
    for (std::size_t i = 0; i < at.size(); ++i)
      i == 0 ? cairo_move_to(cr, at[i].x(), at[i].y())
             : cairo_line_to(cr, at[i].x(), at[i].y());
    if (pass == 0)
      cairo_set_source_rgb(cr, 1, 1, 1), cairo_set_line_width(cr, 4.5);
    else if (style == "floorplan" || style == "occupancy")
      cairo_set_source_rgb(cr, 0.85, 0.0, 0.0), cairo_set_line_width(cr, 2.0);
    else
      cairo_set_source_rgb(cr, 0.1, 0.1, 0.1), cairo_set_line_width(cr, 2.0);
    cairo_stroke(cr);
  }
  const Eigen::Vector2d& s = at.front();
  const Eigen::Vector2d& f = at.back();
  cairo_arc(cr, s.x(), s.y(), 6, 0, 2 * M_PI);
  cairo_set_source_rgb(cr, 0.0, 0.65, 0.2);
  cairo_fill_preserve(cr);
  cairo_set_source_rgb(cr, 1, 1, 1);
  cairo_set_line_width(cr, 1.5);
  cairo_stroke(cr);
  cairo_arc(cr, f.x(), f.y(), 7, 0, 2 * M_PI);
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_set_line_width(cr, 2.0);
  cairo_stroke(cr);
}

/** A scale bar of a round length near a quarter of the map's width, at (x, y) on a white
 *  box. */
void
drawScaleBar(cairo_t* cr, double map_width_m, double scale, double x, double y)
{
  cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, 14);
  const double bar_m = niceLength(0.25 * map_width_m);
  const double bar_px = bar_m * scale;
  cairo_set_source_rgba(cr, 1, 1, 1, 0.85);
  cairo_rectangle(cr, x - 6, y - 24, bar_px + 70, 34);
  cairo_fill(cr);
  cairo_set_source_rgb(cr, 0, 0, 0);
  cairo_set_line_width(cr, 3.0);
  cairo_move_to(cr, x, y);
  cairo_line_to(cr, x + bar_px, y);
  cairo_stroke(cr);
  cairo_set_line_width(cr, 1.5);
  for (double xe : {x, x + bar_px}) {
    cairo_move_to(cr, xe, y - 6);
    cairo_line_to(cr, xe, y + 4);
  }
  cairo_stroke(cr);
  cairo_move_to(cr, x + bar_px + 8, y + 5);
  cairo_show_text(cr, formatLength(bar_m).c_str());
}

/** The legend's row, right-aligned at `right`: the height colour bar from lo to hi, or
 *  the floor plan's key. */
void
drawLegend(cairo_t* cr, const std::string& style, double lo, double hi, double right, double y)
{
  cairo_set_font_size(cr, 12);
  if (style == "floorplan") {
    cairo_move_to(cr, right - 300, y + 14);
    cairo_show_text(cr, "dark: walls and objects, grey: floor/ceiling");
    return;
  }
  if (style == "occupancy") {
    cairo_move_to(cr, right - 300, y + 14);
    cairo_show_text(cr, "dark: walls, white: free space, grey: not seen");
    return;
  }
  const double lw = 160, lx = right - lw;
  for (int i = 0; i < static_cast<int>(lw); ++i) {
    const auto c = heightColour(i / (lw - 1));
    cairo_set_source_rgb(cr, c[0], c[1], c[2]);
    cairo_rectangle(cr, lx + i, y, 1, 10);
    cairo_fill(cr);
  }
  char label[96];
  cairo_set_source_rgb(cr, 0, 0, 0);
  std::snprintf(label, sizeof label, "%.1f", lo);
  cairo_move_to(cr, lx, y + 24);
  cairo_show_text(cr, label);
  std::snprintf(label, sizeof label, "%.1f m", hi);
  cairo_text_extents_t ext;
  cairo_text_extents(cr, label, &ext);
  cairo_move_to(cr, lx + lw - ext.width, y + 24);
  cairo_show_text(cr, label);
  const char* title = "height above trajectory";
  cairo_text_extents(cr, title, &ext);
  cairo_move_to(cr, lx - 10 - ext.x_advance, y + 10);
  cairo_show_text(cr, title);
}

/** The caption's lines (the options' and the view's), wrapped to `width` in its font. */
std::vector<std::string>
captionLines(const PictureOptions& opt, const View& view, double width)
{
  std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)> probe(
      cairo_image_surface_create(CAIRO_FORMAT_RGB24, 1, 1), cairo_surface_destroy);
  std::unique_ptr<cairo_t, decltype(&cairo_destroy)> measure(cairo_create(probe.get()),
                                                             cairo_destroy);
  captionFont(measure.get());
  const char* axes[] = {"x", "y", "z"};
  std::vector<std::string> text = opt.caption;
  text.push_back("top view along " + std::string(axes[opt.up]) + "; right: " + axes[view.u] +
                 ", up: " + (view.flip < 0 ? "-" : "") + axes[view.v] +
                 "; trajectory from the green disc to the black ring; blue dashes: loop "
                 "links");
  std::vector<std::string> lines;
  for (const auto& t : text)
    for (auto& l : wrapText(measure.get(), t, width))
      lines.push_back(std::move(l));
  return lines;
}

/** The surface as a PNG, under a temporary name renamed to `path` (io::writeAtomically). */
void
writePng(cairo_surface_t* surface, const std::string& path)
{
  io::writeAtomically(path, [&](const std::string& tmp) {
    const cairo_status_t status = cairo_surface_write_to_png(surface, tmp.c_str());
    if (status != CAIRO_STATUS_SUCCESS)
      throw std::runtime_error(tmp + ": cannot write the picture (" +
                               cairo_status_to_string(status) + ")");
  });
}

} // namespace

std::string
writeMapPicture(const std::string& path,
                const Cloud& map,
                const Poses& trajectory,
                const PictureOptions& opt)
{
  if (trajectory.empty())
    throw std::invalid_argument("writeMapPicture: empty trajectory");
  const View view = makeView(opt.up);
  std::vector<Eigen::Vector2d> traj;
  for (const auto& t : trajectory)
    traj.push_back(view(t));

  // The extent from (at most ~400k) evenly strided points: quantiles need no more.
  std::vector<Eigen::Vector2d> sample;
  const std::size_t stride = std::max<std::size_t>(1, map.size() / 400000);
  for (std::size_t i = 0; i < map.size(); i += stride)
    sample.push_back(view(map[i].data));
  const Extent e = robustExtent(sample, traj, opt.radius);
  const Eigen::Vector2d span = e.hi - e.lo;
  const PixelFrame px{e.lo, e.hi, opt.size / span.maxCoeff()};
  const int w = std::max(1, static_cast<int>(std::ceil(span.x() * px.scale)));
  const int h = std::max(1, static_cast<int>(std::ceil(span.y() * px.scale)));
  const std::string style = opt.style != "auto" ? opt.style
                            : opt.scans.empty()
                                ? chooseStyle(map, trajectory, opt.up, opt.num_threads)
                                : "occupancy";
  if (style == "occupancy" && opt.scans.size() != trajectory.size())
    throw std::invalid_argument("writeMapPicture: the occupancy style needs a scan per pose");
  const HeightGrid grid = style == "occupancy"
                              ? occupancyGrid(trajectory, view, px, w, h, opt)
                              : heightGrid(map, trajectory, traj, view, px, w, h, style, opt);

  // Canvas: the map, then a band with the legend's row and the caption, wrapped to the
  // canvas width (a tall, narrow map would cut long lines off).
  const int pad = 20, line_h = 20, legend_h = 34;
  const int W = std::max(w + 2 * pad, 700);
  const std::vector<std::string> lines = captionLines(opt, view, W - 2.0 * pad);
  const int H = h + 2 * pad + legend_h + line_h * static_cast<int>(lines.size()) + 10;
  std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)> surface(
      cairo_image_surface_create(CAIRO_FORMAT_RGB24, W, H), cairo_surface_destroy);
  if (cairo_surface_status(surface.get()) != CAIRO_STATUS_SUCCESS)
    throw std::runtime_error(path + ": cannot allocate a " + std::to_string(W) + " x " +
                             std::to_string(H) + " picture");
  paintGrid(surface.get(), grid, style, w, h, pad);

  std::unique_ptr<cairo_t, decltype(&cairo_destroy)> cr_owner(cairo_create(surface.get()),
                                                              cairo_destroy);
  cairo_t* cr = cr_owner.get();
  std::vector<Eigen::Vector2d> at;
  for (const auto& p : traj)
    at.push_back(px(p) + Eigen::Vector2d(pad, pad));
  cairo_rectangle(cr, pad, pad, w, h); // nothing outside the map area
  cairo_clip(cr);
  drawTrajectory(cr, at, opt.loops, style);
  cairo_reset_clip(cr);
  cairo_rectangle(cr, pad - 0.5, pad - 0.5, w + 1, h + 1);
  cairo_set_source_rgb(cr, 0.6, 0.6, 0.6);
  cairo_set_line_width(cr, 1.0);
  cairo_stroke(cr);
  drawScaleBar(cr, span.x(), px.scale, pad + 12, pad + h - 14); // bottom left of the map

  // Caption, below the legend's row.
  captionFont(cr);
  double y = pad + h + legend_h + 14;
  for (const auto& l : lines) {
    cairo_move_to(cr, pad, y);
    cairo_show_text(cr, l.c_str());
    y += line_h;
  }
  drawLegend(cr, style, grid.lo, grid.hi, W - pad, pad + h + 8);
  cairo_surface_flush(surface.get());
  writePng(surface.get(), path);
  return style;
}

} // namespace render
} // namespace pcl_parallel
