/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "../io/detail.h" // the text readers' lines, numbers and errors

#include <pcl_parallel/evaluation/relations.h>
#include <pcl_parallel/evaluation/report.h>
#include <pcl_parallel/pose_math.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <nlohmann/json.hpp> // here only: the installed headers do not need it
#include <numeric>
#include <stdexcept>

namespace pcl_parallel {
namespace evaluation {

std::vector<Relation>
loadRelations(const std::string& path)
{
  std::vector<Relation> relations;
  io::detail::forEachLine(path, [&](const std::string& line, std::size_t line_no) {
    if (line[line.find_first_not_of(io::detail::kSpace)] == '#')
      return;
    io::detail::Fields fields(line);
    double v[8];
    std::size_t k = 0;
    for (std::string_view field; fields.next(field); ++k) {
      if (k == 8)
        io::detail::fail(path, line_no, "more than 8 numbers (t1 t2 x y z roll pitch yaw)");
      if (!io::detail::parseNumber(field, v[k]) || !std::isfinite(v[k]))
        io::detail::fail(path,
                         line_no,
                         "column " + std::to_string(k + 1) +
                             " is not a finite number: " + io::detail::quoted(field));
    }
    if (k != 8)
      io::detail::fail(path,
                       line_no,
                       "expected 8 numbers (t1 t2 x y z roll pitch yaw), got " +
                           std::to_string(k));
    Relation r;
    r.t1 = v[0];
    r.t2 = v[1];
    r.motion.topLeftCorner<3, 3>() = eulerZYXToRotation(v[5], v[6], v[7]);
    r.motion.topRightCorner<3, 1>() = Eigen::Vector3d(v[2], v[3], v[4]);
    r.line = line_no;
    relations.push_back(r);
  });
  if (relations.empty())
    io::detail::fail(path, 0, "holds no relation (t1 t2 x y z roll pitch yaw per line)");
  return relations;
}

MeanStd
meanStd(const std::vector<double>& values)
{
  MeanStd m;
  if (values.empty())
    return m;
  const double n = static_cast<double>(values.size());
  m.mean = std::accumulate(values.begin(), values.end(), 0.0) / n;
  if (values.size() < 2)
    return m;
  double squares = 0.0;
  for (const double v : values)
    squares += (v - m.mean) * (v - m.mean);
  m.std = std::sqrt(squares / (n - 1.0)); // the sample deviation (see MeanStd)
  return m;
}

namespace {

/** The index of the stamp nearest to t among stamps sorted by `order`, or -1 when none
 *  lies within max_diff. */
std::ptrdiff_t
nearestStamp(const std::vector<double>& stamps,
             const std::vector<std::size_t>& order,
             double t,
             double max_diff)
{
  const auto it = std::lower_bound(
      order.begin(), order.end(), t, [&](std::size_t k, double x) { return stamps[k] < x; });
  std::ptrdiff_t best = -1;
  double best_diff = max_diff;
  for (auto c = (it == order.begin() ? it : it - 1); c != order.end() && c <= it; ++c) {
    const double diff = std::abs(stamps[*c] - t);
    if (diff <= best_diff && (best < 0 || diff < best_diff)) {
      best = static_cast<std::ptrdiff_t>(*c);
      best_diff = diff;
    }
  }
  return best;
}

Eigen::Matrix4d
inverse(const Eigen::Matrix4d& pose)
{
  Eigen::Matrix4d inv = Eigen::Matrix4d::Identity();
  inv.topLeftCorner<3, 3>() = pose.topLeftCorner<3, 3>().transpose();
  inv.topRightCorner<3, 1>() = -inv.topLeftCorner<3, 3>() * pose.topRightCorner<3, 1>();
  return inv;
}

std::vector<double>
squared(std::vector<double> values)
{
  for (double& v : values)
    v *= v;
  return values;
}

} // namespace

RelationError
relationError(const std::vector<double>& stamps,
              const Poses& poses,
              const std::vector<Relation>& relations,
              double max_diff)
{
  if (stamps.size() != poses.size())
    throw std::invalid_argument("relationError: " + std::to_string(stamps.size()) +
                                " stamps for " + std::to_string(poses.size()) + " poses");
  if (!(max_diff >= 0.0))
    throw std::invalid_argument("relationError: max_diff must be >= 0");
  std::vector<std::size_t> order(stamps.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return stamps[a] < stamps[b];
  });
  RelationError e;
  e.relations = relations.size();
  e.max_diff = max_diff;
  for (const Relation& r : relations) {
    const std::ptrdiff_t i = nearestStamp(stamps, order, r.t1, max_diff);
    const std::ptrdiff_t j = nearestStamp(stamps, order, r.t2, max_diff);
    if (i < 0 || j < 0)
      continue;
    // Kümmerle et al. Eq. 1: δ_ij ⊖ δ*_ij, the estimate's motion in the measured one's frame.
    const Eigen::Matrix4d motion = inverse(poses[i]) * poses[j];
    const Eigen::Matrix4d error = inverse(r.motion) * motion;
    e.translation_m.push_back(error.topRightCorner<3, 1>().norm());
    e.rotation_deg.push_back(rotationAngle(error.topLeftCorner<3, 3>()) * 180.0 / M_PI);
  }
  e.used = e.translation_m.size();
  e.unmatched = e.relations - e.used;
  e.translation = meanStd(e.translation_m);
  e.translation_squared = meanStd(squared(e.translation_m));
  e.rotation = meanStd(e.rotation_deg);
  e.rotation_squared = meanStd(squared(e.rotation_deg));
  return e;
}

RelationFileEvaluation
evaluateRelationsFile(const std::string& estimate_path,
                      const std::string& relations_path,
                      double max_diff,
                      double frames_unit)
{
  RelationFileEvaluation f;
  f.estimate_path = estimate_path;
  f.relations_path = relations_path;
  f.estimate = io::loadTrajectory(estimate_path, frames_unit);
  if (f.estimate.timestamps.empty())
    throw std::runtime_error(estimate_path + " has no time stamps (" +
                             io::toString(f.estimate.format) +
                             "), and relations name poses by time: give a TUM file");
  requireRigidMotions(f.estimate.poses, estimate_path);
  const std::vector<Relation> relations = loadRelations(relations_path);
  f.errors = relationError(f.estimate.timestamps, f.estimate.poses, relations, max_diff);
  if (f.errors.used == 0)
    throw std::runtime_error("no relation of " + relations_path + " has both its times among " +
                             estimate_path + "'s within --max-diff " +
                             std::to_string(max_diff) + " s");
  return f;
}

void
printRelationEvaluation(std::ostream& out, const RelationFileEvaluation& f)
{
  const std::ios::fmtflags flags = out.flags();
  const std::streamsize precision = out.precision();
  const RelationError& e = f.errors;
  out << "estimate      " << describe(f.estimate_path, f.estimate) << '\n'
      << "relations     " << f.relations_path << " (" << e.relations << " relations)\n"
      << "matched       " << e.used << " relations by timestamp (max diff " << std::fixed
      << std::setprecision(6) << e.max_diff << " s), " << e.unmatched << " unmatched\n\n";
  out << std::left << std::setw(44) << "relation error (Kuemmerle et al. 2009)" << std::right
      << std::setw(12) << "mean" << std::setw(12) << "std" << '\n';
  const auto row = [&](const char* name, const MeanStd& m) {
    out << "  " << std::left << std::setw(42) << name << std::right << std::setprecision(6)
        << std::setw(12) << m.mean << std::setw(12) << m.std << '\n';
  };
  row("translation [m]", e.translation);
  row("translation squared [m^2]", e.translation_squared);
  row("rotation [deg]", e.rotation);
  row("rotation squared [deg^2]", e.rotation_squared);
  out.flags(flags);
  out.precision(precision);
}

std::string
toJson(const RelationFileEvaluation& f, int indent)
{
  using nlohmann::json;
  const auto pair = [](const MeanStd& m) { return json{{"mean", m.mean}, {"std", m.std}}; };
  const RelationError& e = f.errors;
  const json j = {{"metric", "relations (Kuemmerle et al. 2009)"},
                  {"relations", e.relations},
                  {"used", e.used},
                  {"unmatched", e.unmatched},
                  {"max_diff_s", e.max_diff},
                  {"translation_m", pair(e.translation)},
                  {"translation_squared_m2", pair(e.translation_squared)},
                  {"rotation_deg", pair(e.rotation)},
                  {"rotation_squared_deg2", pair(e.rotation_squared)},
                  {"estimate",
                   {{"path", f.estimate_path},
                    {"format", io::toString(f.estimate.format)},
                    {"poses", f.estimate.poses.size()},
                    {"timestamps", !f.estimate.timestamps.empty()}}},
                  {"relations_file", f.relations_path}};
  return j.dump(indent, ' ', false, json::error_handler_t::replace);
}

} // namespace evaluation
} // namespace pcl_parallel
