/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/reduction.h>
#include <pcl_parallel/slam/preprocess.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <string>

namespace pcl_parallel {
namespace slam {

namespace {

/** Passes over a scan of at least this many points run in parallel (below, their start-up
 *  costs more than they save). */
constexpr std::size_t kParallelPoints = 20000;

unsigned
threadsFor(std::size_t points, unsigned num_threads)
{
  return points >= kParallelPoints ? resolveNumberOfThreads(num_threads) : 1;
}

/** cropRange; with `times`, their kept ones into `kept_times`. In parallel: each block of
 *  points counts what it keeps, then copies it to its place (a prefix sum), so the kept
 *  points stay in scan order for any thread count. */
Cloud::Ptr
crop(const Cloud& scan,
     double min_range,
     double max_range,
     const std::vector<float>* times,
     std::vector<float>* kept_times,
     unsigned num_threads)
{
  const double lo = min_range * min_range, hi = max_range * max_range;
  const auto keep = [&](const PointT& p) {
    if (!(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)))
      return false;
    const double r2 = double(p.x) * p.x + double(p.y) * p.y + double(p.z) * p.z;
    return r2 > 0.0 && r2 >= lo && r2 <= hi; // at the origin: a driver's no-return
  };
  const std::size_t n = scan.size();
  const unsigned threads = threadsFor(n, num_threads);
  const std::size_t blocks = threads > 1 ? 4 * std::size_t{threads} : 1;
  const auto begin = [&](std::size_t b) { return n * b / blocks; };
  std::vector<std::size_t> first(blocks + 1, 0);
  parallelFor(blocks, threads, 1, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t b = b0; b < b1; ++b)
      first[b + 1] = static_cast<std::size_t>(
          std::count_if(scan.begin() + begin(b), scan.begin() + begin(b + 1), keep));
  });
  for (std::size_t b = 0; b < blocks; ++b)
    first[b + 1] += first[b];
  Cloud::Ptr out(new Cloud);
  out->resize(first.back());
  if (times)
    kept_times->resize(first.back());
  parallelFor(blocks, threads, 1, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t b = b0; b < b1; ++b) {
      std::size_t j = first[b];
      for (std::size_t i = begin(b); i < begin(b + 1); ++i)
        if (keep(scan[i])) {
          if (times)
            (*kept_times)[j] = (*times)[i];
          (*out)[j++] = scan[i];
        }
    }
  });
  return out;
}

} // namespace

double
median(std::vector<double> values)
{
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

double
medianRange(const Cloud& scan)
{
  std::vector<float> r;
  r.reserve(scan.size());
  for (const auto& p : scan)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z))
      r.push_back(p.getVector3fMap().norm());
  if (r.empty())
    return 0.0;
  std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
  return r[r.size() / 2];
}

void
requireOnePerPoint(const Cloud& scan, std::size_t times, const std::string& context)
{
  if (times != scan.size())
    throw std::invalid_argument(context + ": " + std::to_string(times) + " point times for " +
                                std::to_string(scan.size()) + " points");
}

void
requirePointsInRange(const Cloud& cropped, std::size_t index)
{
  if (cropped.empty())
    throw std::invalid_argument("scan " + std::to_string(index) +
                                " has no finite points in range (away from the origin)");
}

void
requireScannerFrame(const Cloud& scan, const std::string& context, unsigned num_threads)
{
  // A scanner sits inside what it sees, or a few spreads from it (a forward-looking
  // solid-state LiDAR); 100 spreads is a field of view under 2 degrees.
  constexpr double kMaxSpreads = 100.0;
  if (scan.empty())
    return;
  // Sums over fixed blocks in a fixed order: the verdict is the same for any thread count.
  const std::size_t n = scan.size();
  const unsigned threads = threadsFor(n, num_threads);
  constexpr std::size_t kBlock = 4096;
  const Eigen::Vector3d sum = deterministicReduce(
      n,
      threads,
      Eigen::Vector3d(Eigen::Vector3d::Zero()),
      [&](std::size_t b, std::size_t e) {
        Eigen::Vector3d s = Eigen::Vector3d::Zero();
        for (std::size_t i = b; i < e; ++i)
          s += scan[i].getVector3fMap().cast<double>();
        return s;
      },
      [](Eigen::Vector3d& total, const Eigen::Vector3d& s) { total += s; },
      kBlock);
  const Eigen::Vector3d centroid = sum / double(n);
  const double squares = deterministicReduce(
      n,
      threads,
      0.0,
      [&](std::size_t b, std::size_t e) {
        double s = 0.0;
        for (std::size_t i = b; i < e; ++i)
          s += (scan[i].getVector3fMap().cast<double>() - centroid).squaredNorm();
        return s;
      },
      [](double& total, double s) { total += s; },
      kBlock);
  const double spread = std::sqrt(squares / double(n));
  if (spread > 0.0 && centroid.norm() > kMaxSpreads * spread) {
    char numbers[160];
    std::snprintf(numbers,
                  sizeof numbers,
                  "its points lie %.6g from the origin, %.0f times their spread (%.3g)",
                  centroid.norm(),
                  centroid.norm() / spread,
                  spread);
    throw std::invalid_argument(
        context + ": " + numbers +
        ": a scan must be in its scanner's own frame, the scanner at the origin (a "
        "georeferenced or pre-registered scan: move it back by its scan position first)");
  }
}

bool
spansSweep(const std::vector<double>& times)
{
  return std::any_of(times.begin(), times.end(), [&](double t) { return t != times.front(); });
}

std::vector<float>
sweepTimes(const std::vector<double>& times)
{
  return spansSweep(times) ? sweepFractions(times) : std::vector<float>();
}

Cloud::Ptr
cropRange(const Cloud& scan, double min_range, double max_range, unsigned num_threads)
{
  return crop(scan, min_range, max_range, nullptr, nullptr, num_threads);
}

Cloud::Ptr
cropRange(const Cloud& scan,
          double min_range,
          double max_range,
          const std::vector<float>& times,
          std::vector<float>& kept_times,
          unsigned num_threads)
{
  requireOnePerPoint(scan, times.size(), "cropRange");
  kept_times.clear();
  return crop(scan, min_range, max_range, &times, &kept_times, num_threads);
}

std::vector<float>
sweepFractions(const std::vector<double>& times)
{
  for (std::size_t i = 0; i < times.size(); ++i)
    if (!std::isfinite(times[i]))
      throw std::invalid_argument("sweepFractions: the time of point " + std::to_string(i) +
                                  " is not a finite number");
  std::vector<float> out(times.size(), 0.5f);
  if (times.empty())
    return out;
  const auto [lo, hi] = std::minmax_element(times.begin(), times.end());
  const double first = *lo, span = *hi - *lo;
  if (span > 0.0)
    for (std::size_t i = 0; i < times.size(); ++i)
      out[i] = static_cast<float>((times[i] - first) / span);
  return out;
}

namespace {

/** A relative motion as a twist (ω, v), motion = exp([ω v]), kept with what its
 *  exponential at s needs: exp(s ξ) = (R(s θ), s v + a(s) ω×v + b(s) ω×(ω×v)), with
 *  a(s) = (1 - cos sθ) / θ², b(s) = (sθ - sin sθ) / θ³: the SE(3) exponential, V(s ω) s v
 *  (Sophus' SE3::exp and SE3::log compute the same). */
class ScrewMotion {
public:
  explicit ScrewMotion(const Pose& motion)
  {
    const Eigen::AngleAxisd aa(Eigen::Matrix3d(motion.topLeftCorner<3, 3>()));
    theta_ = aa.angle();
    axis_ = aa.axis();
    const Eigen::Vector3d w = theta_ * axis_, t = motion.topRightCorner<3, 1>();
    // v = V(ω)⁻¹ t, V⁻¹ = I - ω×/2 + c ω×ω×, c = (1 - (θ/2) cot(θ/2)) / θ²; its series
    // below θ = 0.01, where the closed form cancels.
    const double c =
        theta_ < 1e-2 ? 1.0 / 12.0 + theta_ * theta_ / 720.0
                      : (1.0 - theta_ * std::sin(theta_) / (2.0 * (1.0 - std::cos(theta_)))) /
                            (theta_ * theta_);
    v_ = t - 0.5 * w.cross(t) + c * w.cross(w.cross(t));
    wv_ = w.cross(v_);
    wwv_ = w.cross(wv_);
  }

  /** exp(s ξ) applied to p: Rodrigues' formula, sharing one sine and cosine with the
   *  translation (deskewing calls this per point). */
  Eigen::Vector3d
  apply(double s, const Eigen::Vector3d& p) const
  {
    const double x = s * theta_, cos_x = std::cos(x), sin_x = std::sin(x);
    return cos_x * p + sin_x * axis_.cross(p) + (1.0 - cos_x) * axis_.dot(p) * axis_ +
           translation(s, cos_x, sin_x);
  }

  Pose
  at(double s) const
  {
    const double x = s * theta_;
    Pose out = Pose::Identity();
    out.topLeftCorner<3, 3>() = Eigen::AngleAxisd(x, axis_).toRotationMatrix();
    out.topRightCorner<3, 1>() = translation(s, std::cos(x), std::sin(x));
    return out;
  }

private:
  /** The translation of exp(s ξ), given cos and sin of s θ. */
  Eigen::Vector3d
  translation(double s, double cos_x, double sin_x) const
  {
    const double x = s * theta_;
    double a, b; // series below x = 1e-4: cancellation, and θ = 0
    if (std::abs(x) < 1e-4) {
      a = s * s * (0.5 - x * x / 24.0);
      b = s * s * s * (1.0 / 6.0 - x * x / 120.0);
    }
    else {
      a = (1.0 - cos_x) / (theta_ * theta_);
      b = (x - sin_x) / (theta_ * theta_ * theta_);
    }
    return s * v_ + a * wv_ + b * wwv_;
  }

  double theta_;
  Eigen::Vector3d axis_, v_, wv_, wwv_;
};

} // namespace

Pose
interpolateMotion(const Pose& motion, double s)
{
  return ScrewMotion(motion).at(s);
}

Pose
extrapolateMotion(const Pose& step, double span, const Pose& previous, double previous_span)
{
  const bool timed = span > 0.0 && previous_span > 0.0;
  // The previous velocity over this step's time; the change between the middles of the
  // steps ((span + previous_span) / 2 apart) carried on by span / 2.
  const Pose before = timed ? interpolateMotion(previous, span / previous_span) : previous;
  return step * interpolateMotion(Pose(before.inverse() * step),
                                  timed ? span / (span + previous_span) : 0.5);
}

Pose
sweepMotion(const Pose& motion, double span, double sweep_period)
{
  if (sweep_period <= 0.0 || !(span > sweep_period))
    return motion;
  return interpolateMotion(motion, sweep_period / span);
}

Pose
sweepMotionAt(const Poses& poses,
              const std::vector<double>& stamps,
              std::size_t k,
              double sweep_period)
{
  const std::size_t n = poses.size();
  if (k >= n)
    throw std::out_of_range("sweepMotionAt: scan " + std::to_string(k) + " of " +
                            std::to_string(n) + " poses");
  if (n < 2)
    return Pose::Identity();
  const std::size_t a = k > 0 ? k - 1 : 0, b = std::min(k + 1, n - 1);
  const Pose motion = poses[a].inverse() * poses[b];
  if (sweep_period > 0.0 && stamps.size() == n)
    return sweepMotion(motion, stamps[b] - stamps[a], sweep_period);
  return b - a == 2 ? interpolateMotion(motion, 0.5) : motion; // consecutive sweeps
}

namespace {

/** p' = motion^(t - 1/2) p with t = time(i, p) for each point i. */
template <typename Time>
Cloud::Ptr
deskewAt(const Cloud& scan, const Pose& motion, unsigned num_threads, Time time)
{
  Cloud::Ptr out(new Cloud(scan));
  const ScrewMotion screw(motion);
  const std::size_t n = scan.size();
  const unsigned threads = threadsFor(n, num_threads);
  parallelFor(n, threads, evenGrain(n, threads), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const PointT& p = scan[i];
      const double s = time(i, p) - 0.5; // motion^s, s in [-1/2, 1/2]
      (*out)[i].getVector3fMap() =
          screw.apply(s, p.getVector3fMap().cast<double>()).cast<float>();
    }
  });
  return out;
}

} // namespace

Cloud::Ptr
deskew(const Cloud& scan, const Pose& motion, unsigned num_threads, bool clockwise)
{
  return deskewAt(scan, motion, num_threads, [clockwise](std::int64_t, const PointT& p) {
    return sweepTime(p, clockwise);
  });
}

Cloud::Ptr
deskew(const Cloud& scan,
       const std::vector<float>& sweep_times,
       const Pose& motion,
       unsigned num_threads)
{
  requireOnePerPoint(scan, sweep_times.size(), "deskew");
  return deskewAt(scan, motion, num_threads, [&](std::int64_t i, const PointT&) {
    return static_cast<double>(sweep_times[static_cast<std::size_t>(i)]);
  });
}

namespace {
/** A sweep time consistent to this (a thousandth of a sweep) is the point's own. */
constexpr double kSeamTolerance = 1e-3;
} // namespace

Cloud::Ptr
redeskew(const Cloud& deskewed,
         const Pose& from,
         const Pose& to,
         bool clockwise,
         unsigned num_threads)
{
  const ScrewMotion back(Pose(from.inverse())), on(to);
  const auto time = [clockwise](const Eigen::Vector3d& p) { return sweepTime(p, clockwise); };
  // The measured time t of a deskewed point q solves t = time(from^-(t - 1/2) q): a fixed
  // point, found from q's own azimuth; a point the deskewing moved across the sweep's seam
  // (its azimuth behind the scanner) is found from the seam's side instead.
  const auto measured = [&](const Eigen::Vector3d& q) {
    double best = 0.0, residual = std::numeric_limits<double>::infinity();
    for (const double start : {time(q), 0.0, 1.0}) {
      double t = start;
      for (int k = 0; k < 3; ++k)
        t = time(back.apply(t - 0.5, q));
      const double r = std::abs(time(back.apply(t - 0.5, q)) - t);
      if (r < residual)
        residual = r, best = t;
      if (residual < kSeamTolerance)
        break;
    }
    return best;
  };
  Cloud::Ptr out(new Cloud(deskewed));
  const std::size_t n = deskewed.size();
  const unsigned threads = threadsFor(n, num_threads);
  parallelFor(n, threads, evenGrain(n, threads), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const Eigen::Vector3d q = deskewed[i].getVector3fMap().cast<double>();
      const double s = measured(q) - 0.5;
      (*out)[i].getVector3fMap() = on.apply(s, back.apply(s, q)).cast<float>();
    }
  });
  return out;
}

Cloud::Ptr
deskewSweep(const Cloud& scan,
            const std::vector<float>& sweep_times,
            const Pose& motion,
            bool clockwise,
            unsigned num_threads)
{
  return sweep_times.empty() ? deskew(scan, motion, num_threads, clockwise)
                             : deskew(scan, sweep_times, motion, num_threads);
}

} // namespace slam
} // namespace pcl_parallel
