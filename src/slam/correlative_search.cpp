/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/slam/correlative_search.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <utility>

namespace pcl_parallel {
namespace slam {

namespace {

/** The coarse search's cell, in fine cells. */
constexpr int kCoarseCells = 2;
/** The coarse search tries at most this many cells either way (257 x 257 translations
 *  a heading): 25 median ranges at the pipeline's cell, past any scan's 90th percentile. */
constexpr int kMaxCoarseSteps = 128;
/** Coarse peaks refined by the fine search. */
constexpr std::size_t kCoarsePeaks = 16;
/** The fine search: headings within half a coarse step, translations within a coarse
 *  cell (plus one fine cell) of a coarse peak, heights within kFineCells too. */
constexpr int kFineHeadings = 2; ///< either side, at a quarter of the coarse step
constexpr int kFineCells = kCoarseCells / 2 + 1;
/** The grids reach at most this many cells from the origin horizontally, and hold at most
 *  kMaxCells (a byte each): taller scenes keep a band about the scanner's height. */
constexpr int kMaxHalfCells = 1024;
constexpr std::size_t kMaxCells = std::size_t(1) << 26;

/** The horizontal plane and the vertical: u, v, up right-handed (u x v = up). */
struct Frame {
  Eigen::Vector3d u, v, up;

  explicit Frame(const Eigen::Vector3d& vertical)
      : up(vertical.normalized())
  {
    u = up.unitOrthogonal();
    v = up.cross(u);
  }

  Eigen::Vector3d
  of(const PointT& point) const
  {
    const Eigen::Vector3d p = point.getVector3fMap().cast<double>();
    return {p.dot(u), p.dot(v), p.dot(up)};
  }
};

/** How near a cell lies to a target point, a coarse likelihood field (Olson 2009): 2 in
 *  the point's cell, 1 in the 26 around it, 0 elsewhere; in the search frame, centred on
 *  the origin horizontally. A source point scores the value of the cell it falls in. */
class LikelihoodField {
public:
  LikelihoodField(const std::vector<Eigen::Vector3d>& points, double cell, int half_cells)
      : cell_(cell)
      , half_(half_cells)
      , side_(2 * half_cells)
  {
    double low = std::numeric_limits<double>::infinity(), high = -low;
    for (const auto& p : points)
      low = std::min(low, p.z()), high = std::max(high, p.z());
    low_ = std::floor(low / cell) - 1;
    layers_ = points.empty() ? 0 : static_cast<int>(std::floor(high / cell) - low_) + 2;
    const std::size_t column = static_cast<std::size_t>(side_) * side_;
    if (column * layers_ > kMaxCells) { // a band about the scanner's height
      layers_ = static_cast<int>(std::max<std::size_t>(1, kMaxCells / column));
      low_ = -std::floor(layers_ / 2.0);
    }
    near_.assign(static_cast<std::size_t>(side_) * side_ * layers_, 0);
    for (const auto& p : points) {
      const int i = index(p.x()), j = index(p.y()), k = layer(p.z());
      if (i < 0 || j < 0 || k < 0)
        continue; // outside the grid (its reach, or the band of a tall scene)
      for (int di = -1; di <= 1; ++di)
        for (int dj = -1; dj <= 1; ++dj)
          for (int dk = -1; dk <= 1; ++dk)
            if (inside(i + di, j + dj, k + dk)) {
              const std::uint8_t near = di == 0 && dj == 0 && dk == 0 ? 2 : 1;
              std::uint8_t& o = near_[offset(i + di, j + dj, k + dk)];
              o = std::max(o, near);
            }
    }
  }

  int
  index(double x) const
  {
    const double i = std::floor(x / cell_) + half_;
    return i < 0.0 || i >= side_ ? -1 : static_cast<int>(i);
  }

  int
  layer(double z) const
  {
    const double k = std::floor(z / cell_) - low_;
    return k < 0.0 || k >= layers_ ? -1 : static_cast<int>(k);
  }

  bool
  inside(int i, int j, int k) const
  {
    return i >= 0 && i < side_ && j >= 0 && j < side_ && k >= 0 && k < layers_;
  }

  int
  at(int i, int j, int k) const
  {
    return inside(i, j, k) ? near_[offset(i, j, k)] : 0;
  }

  int
  value(const Eigen::Vector3d& p) const
  {
    return at(index(p.x()), index(p.y()), layer(p.z()));
  }

  /** scores[(a + n) * (2n + 1) + b + n] += at(i + a, j + b, k) for a, b in [-n, n]: one
   *  point's votes for every translation of the window. The sizes are read into locals,
   *  so the writes to scores cannot alias them. */
  void
  addWindow(int i, int j, int k, int n, int* scores) const
  {
    const int side = side_, layers = layers_, width = 2 * n + 1;
    const std::uint8_t* near = near_.data();
    if (k < 0 || k >= layers)
      return;
    for (int a = std::max(-n, -i); a <= n && i + a < side; ++a) {
      int* row = scores + static_cast<std::size_t>(a + n) * width + n;
      const std::uint8_t* column = near + static_cast<std::size_t>(i + a) * side * layers + k;
      for (int b = std::max(-n, -j); b <= n && j + b < side; ++b)
        row[b] += column[static_cast<std::size_t>(j + b) * layers];
    }
  }

private:
  std::size_t
  offset(int i, int j, int k) const
  {
    return (static_cast<std::size_t>(i) * side_ + j) * layers_ + k;
  }

  double cell_;
  int half_, side_;
  double low_ = 0.0;
  int layers_ = 0;
  std::vector<std::uint8_t> near_;
};

/** A pose in the plane (heading about up, translation) and how many source points it
 *  lands on the target's. */
struct Peak {
  int score = -1;
  double heading = 0.0;
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
};

/** The points turned by `heading` about the vertical (the search frame's z). */
std::vector<Eigen::Vector3d>
turned(const std::vector<Eigen::Vector3d>& points, double heading)
{
  const double c = std::cos(heading), s = std::sin(heading);
  std::vector<Eigen::Vector3d> out;
  out.reserve(points.size());
  for (const auto& p : points)
    out.emplace_back(c * p.x() - s * p.y(), s * p.x() + c * p.y(), p.z());
  return out;
}

/** What the turned source points score moved by `translation`. */
int
score(const std::vector<Eigen::Vector3d>& turned_points,
      const LikelihoodField& target,
      const Eigen::Vector3d& translation)
{
  int n = 0;
  for (const auto& p : turned_points)
    n += target.value(p + translation);
  return n;
}

/** Peaks best first, each kept only if no better one lies within `distance` and `turn`
 *  radians of it (non-maximum suppression); at most `count`. */
std::vector<Peak>
distinctPeaks(std::vector<Peak> peaks, double distance, double turn, std::size_t count)
{
  std::stable_sort(peaks.begin(), peaks.end(), [](const Peak& a, const Peak& b) {
    return a.score > b.score;
  });
  std::vector<Peak> kept;
  for (const Peak& p : peaks) {
    if (kept.size() == count || p.score <= 0)
      break;
    const bool near = std::any_of(kept.begin(), kept.end(), [&](const Peak& k) {
      const double dh = std::remainder(p.heading - k.heading, 2.0 * M_PI);
      return (p.translation - k.translation).norm() <= distance && std::abs(dh) <= turn;
    });
    if (!near)
      kept.push_back(p);
  }
  return kept;
}

/** The cloud's points in the search frame within `reach` of the origin horizontally. */
std::vector<Eigen::Vector3d>
within(const Cloud& cloud, const Frame& frame, double reach)
{
  std::vector<Eigen::Vector3d> out;
  out.reserve(cloud.size());
  for (const auto& point : cloud) {
    const Eigen::Vector3d p = frame.of(point);
    if (p.allFinite() && p.head<2>().squaredNorm() <= reach * reach)
      out.push_back(p);
  }
  return out;
}

/** As far as the target reaches: its 90th percentile range, at least a cell; 0 where it
 *  has no finite point. */
double
targetReach(const Cloud& target, const Frame& frame, double cell)
{
  std::vector<double> ranges;
  ranges.reserve(target.size());
  for (const auto& p : target)
    if (const double r = frame.of(p).head<2>().norm(); std::isfinite(r))
      ranges.push_back(r);
  if (ranges.empty())
    return 0.0;
  const auto at = ranges.begin() + static_cast<std::ptrdiff_t>(0.9 * (ranges.size() - 1));
  std::nth_element(ranges.begin(), at, ranges.end());
  return std::max(*at, cell);
}

/** Every k-th point, at most `max_points`: the scan is reduced, so spread. */
void
thin(std::vector<Eigen::Vector3d>& points, std::size_t max_points)
{
  if (points.size() <= max_points)
    return;
  const std::size_t step = (points.size() + max_points - 1) / max_points;
  std::vector<Eigen::Vector3d> every;
  for (std::size_t i = 0; i < points.size(); i += step)
    every.push_back(points[i]);
  points.swap(every);
}

/** Whether the points' heights span less than a cell. */
bool
isFlat(const std::vector<Eigen::Vector3d>& points, double cell)
{
  const auto [low, high] = std::minmax_element(
      points.begin(), points.end(), [](const auto& a, const auto& b) { return a.z() < b.z(); });
  return points.empty() || high->z() - low->z() < cell;
}

/** The coarse headings searched, in steps of 2 pi / headings: the whole circle, or those
 *  within max_turn (> 0) either side of zero. */
std::vector<double>
coarseHeadings(int headings, double max_turn)
{
  const double step = 2.0 * M_PI / headings;
  std::vector<double> out;
  if (max_turn > 0.0 && max_turn < M_PI) {
    const int n = std::min(static_cast<int>(std::floor(max_turn / step)), (headings - 1) / 2);
    for (int h = -n; h <= n; ++h)
      out.push_back(h * step);
  }
  else
    for (int h = 0; h < headings; ++h)
      out.push_back(h * step);
  return out;
}

/** Coarse: every heading given, every translation in coarse cells within the radius
 *  (the heights as they are: the coarse cells' dilation takes a step up or down); the
 *  best distinct peaks; `step` the headings' spacing. */
std::vector<Peak>
coarsePeaks(const std::vector<Eigen::Vector3d>& points,
            const LikelihoodField& coarse,
            double coarse_cell,
            double radius,
            const std::vector<double>& headings,
            double step,
            unsigned threads)
{
  const int n = std::min(kMaxCoarseSteps, static_cast<int>(std::ceil(radius / coarse_cell)));
  const int side = 2 * n + 1;
  std::vector<std::vector<Peak>> best(headings.size());
  parallelFor(headings.size(), threads, 1, [&, n, side](std::size_t h0, std::size_t h1) {
    for (std::size_t h = h0; h < h1; ++h) {
      std::vector<int> s(static_cast<std::size_t>(side) * side, 0);
      for (const auto& q : turned(points, headings[h])) {
        const int i = coarse.index(q.x()), j = coarse.index(q.y()), k = coarse.layer(q.z());
        if (i < 0 || j < 0 || k < 0)
          continue;
        coarse.addWindow(i, j, k, n, s.data());
      }
      // This heading's best distinct peaks (memory: a few per heading, not every cell).
      std::vector<Peak> peaks;
      for (int a = -n; a <= n; ++a)
        for (int b = -n; b <= n; ++b)
          if (const int v = s[static_cast<std::size_t>(a + n) * side + b + n];
              v > 0 && a * a + b * b <= n * n)
            peaks.push_back({v, headings[h], Eigen::Vector3d(a, b, 0.0) * coarse_cell});
      best[h] = distinctPeaks(std::move(peaks), coarse_cell, 0.0, kCoarsePeaks);
    }
  });
  std::vector<Peak> peaks;
  for (const auto& b : best) // in heading order: ties keep it
    peaks.insert(peaks.end(), b.begin(), b.end());
  return distinctPeaks(std::move(peaks), coarse_cell, step, kCoarsePeaks);
}

/** Fine: around each coarse peak, `heights` cells up and down too, by direct lookup;
 *  `step` the coarse headings' spacing. */
std::vector<Peak>
finePeaks(const std::vector<Eigen::Vector3d>& points,
          const LikelihoodField& fine,
          const std::vector<Peak>& peaks,
          double cell,
          double step,
          int heights,
          unsigned threads)
{
  std::vector<Peak> refined(peaks.size());
  parallelFor(peaks.size(), threads, 1, [&, step](std::size_t k0, std::size_t k1) {
    for (std::size_t k = k0; k < k1; ++k) {
      Peak best;
      const Eigen::Vector3d centre = peaks[k].translation;
      for (int dh = -kFineHeadings; dh <= kFineHeadings; ++dh) {
        const double heading = peaks[k].heading + dh * step / (2 * kFineHeadings);
        const std::vector<Eigen::Vector3d> turned_points = turned(points, heading);
        for (int a = -kFineCells; a <= kFineCells; ++a)
          for (int b = -kFineCells; b <= kFineCells; ++b)
            for (int c = -heights; c <= heights; ++c) {
              const Eigen::Vector3d t = centre + Eigen::Vector3d(a, b, c) * cell;
              const int s = score(turned_points, fine, t);
              if (s > best.score)
                best = {s, heading, t};
            }
      }
      refined[k] = best;
    }
  });
  return refined;
}

/** A peak as a pose in the scan's frame. */
Pose
toPose(const Peak& p, const Frame& frame)
{
  Pose pose = Pose::Identity();
  pose.topLeftCorner<3, 3>() = Eigen::AngleAxisd(p.heading, frame.up).toRotationMatrix();
  pose.topRightCorner<3, 1>() =
      p.translation.x() * frame.u + p.translation.y() * frame.v + p.translation.z() * frame.up;
  return pose;
}

} // namespace

std::vector<Pose>
correlativeSearch(const Cloud& source,
                  const Cloud& target,
                  const Eigen::Vector3d& up,
                  const CorrelativeSearchParameters& params)
{
  const auto non_negative = [](double x) { return x >= 0.0 && std::isfinite(x); };
  if (!(params.cell > 0.0) || !std::isfinite(params.cell) || params.headings < 1 ||
      !non_negative(params.radius) || !non_negative(params.max_turn) ||
      !non_negative(params.reach) || params.max_points < 1 || !(up.norm() > 0.0))
    throw std::invalid_argument("correlativeSearch: cell > 0, radius, max_turn and reach "
                                ">= 0, headings >= 1, max_points >= 1 and a non-zero up "
                                "axis needed");
  const Frame frame(up);
  const double radius =
      params.radius == 0.0 ? targetReach(target, frame, params.cell) : params.radius;
  if (radius == 0.0)
    return {};
  const double coarse_cell = kCoarseCells * params.cell;
  const int half_fine =
      std::min(kMaxHalfCells,
               static_cast<int>(std::ceil((params.reach > 0.0 ? params.reach : 2.0 * radius) /
                                          params.cell)));
  const double reach = half_fine * params.cell;
  const std::vector<Eigen::Vector3d> target_points = within(target, frame, reach);
  std::vector<Eigen::Vector3d> points = within(source, frame, reach);
  if (target_points.empty() || points.empty())
    return {};
  thin(points, params.max_points);
  const LikelihoodField fine(target_points, params.cell, half_fine);
  const LikelihoodField coarse(
      target_points, coarse_cell, (half_fine + kCoarseCells - 1) / kCoarseCells);
  const unsigned threads = resolveNumberOfThreads(params.num_threads);
  const double step = 2.0 * M_PI / params.headings;
  const std::vector<Peak> peaks = coarsePeaks(points,
                                              coarse,
                                              coarse_cell,
                                              radius,
                                              coarseHeadings(params.headings, params.max_turn),
                                              step,
                                              threads);
  std::vector<Pose> out;
  // Two flat scans (a 2D scanner's) are not moved up or down: only their own layer scores.
  const int heights =
      isFlat(points, params.cell) && isFlat(target_points, params.cell) ? 0 : kFineCells;
  for (const Peak& p :
       distinctPeaks(finePeaks(points, fine, peaks, params.cell, step, heights, threads),
                     2.0 * params.cell,
                     step / 2.0,
                     params.candidates))
    out.push_back(toPose(p, frame));
  return out;
}

} // namespace slam
} // namespace pcl_parallel
