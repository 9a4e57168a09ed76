/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "convert.h"

#include <pcl_parallel/slam/parameters.h>
#include <pcl_parallel/slam/pipeline.h>

#include <cmath>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>

namespace pcl_parallel {
namespace python {

namespace {

// slam::Parameters as Python sees it: a dict per stage (reduction, deskew, matcher, guess,
// loops) whose keys are the C++ fields' names, plus median_range and threads. One table
// of fields serves both directions, so the names cannot drift apart.

std::string
where(const char* stage, const char* field)
{
  return std::string(stage) + "." + field;
}

template <typename T>
T
fromPython(const py::handle& v, const std::string& name)
{
  const bool is_bool = py::isinstance<py::bool_>(v) ||
                       py::str(py::type::of(v)).cast<std::string>() == "<class 'numpy.bool_'>";
  if constexpr (std::is_same_v<T, bool>) {
    if (!is_bool)
      throw std::invalid_argument(name + ": expected a bool");
    return v.cast<bool>();
  }
  else if constexpr (std::is_same_v<T, slam::MatchTarget>) {
    const std::string s = py::isinstance<py::str>(v) ? v.cast<std::string>() : "";
    if (s == "local_map")
      return slam::MatchTarget::kLocalMap;
    if (s == "previous_scan")
      return slam::MatchTarget::kPreviousScan;
    throw std::invalid_argument(name + ": \"local_map\" or \"previous_scan\"");
  }
  else if constexpr (std::is_same_v<T, Eigen::Vector3d>) {
    const std::vector<double> u = toValues(v, name.c_str(), 3);
    const Eigen::Vector3d up(u[0], u[1], u[2]);
    if (!(up.norm() > 0.0))
      throw std::invalid_argument(name + ": a zero vector");
    return up;
  }
  else { // numbers: ints for integer fields, any real for lengths; never NaN or negative
    const bool integral = py::isinstance<py::int_>(v) || py::hasattr(v, "__index__");
    if (is_bool || (!integral && !py::isinstance<py::float_>(v)) ||
        (std::is_integral_v<T> && !integral))
      throw std::invalid_argument(name + std::string(": expected ") +
                                  (std::is_integral_v<T> ? "an int" : "a number"));
    const double d = v.cast<double>();
    if (std::isnan(d) || (!std::is_same_v<T, int> && d < 0.0))
      throw std::invalid_argument(name + ": " + py::str(v).cast<std::string>() +
                                  " is not a number >= 0");
    if constexpr (std::is_integral_v<T>)
      return v.cast<T>();
    else
      return d;
  }
}

template <typename T>
py::object
toPython(const T& value)
{
  if constexpr (std::is_same_v<T, slam::MatchTarget>)
    return py::str(value == slam::MatchTarget::kLocalMap ? "local_map" : "previous_scan");
  else if constexpr (std::is_same_v<T, Eigen::Vector3d>)
    return py::make_tuple(value.x(), value.y(), value.z());
  else
    return py::cast(value);
}

struct Field {
  const char* stage;
  const char* name;
  std::function<void(slam::Parameters&, const py::handle&)> set;
  std::function<py::object(const slam::Parameters&)> get;
};

template <typename S, typename T>
Field
field(const char* stage, S slam::Parameters::*part, const char* name, T S::*member)
{
  return {stage,
          name,
          [=](slam::Parameters& p, const py::handle& v) {
            p.*part.*member = fromPython<T>(v, where(stage, name));
          },
          [=](const slam::Parameters& p) { return toPython(p.*part.*member); }};
}

#define PCL_PARALLEL_FIELD(stage, Type, name)                                                  \
  field(#stage, &slam::Parameters::stage, #name, &slam::Type::name)

const std::vector<Field>&
fields()
{
  static const std::vector<Field> all = {
      PCL_PARALLEL_FIELD(reduction, ReductionParameters, min_range),
      PCL_PARALLEL_FIELD(reduction, ReductionParameters, max_range),
      PCL_PARALLEL_FIELD(reduction, ReductionParameters, voxel_size),
      PCL_PARALLEL_FIELD(reduction, ReductionParameters, source_voxel_size),
      PCL_PARALLEL_FIELD(deskew, DeskewParameters, enabled),
      PCL_PARALLEL_FIELD(deskew, DeskewParameters, sweep_period),
      PCL_PARALLEL_FIELD(deskew, DeskewParameters, sweep_clockwise),
      PCL_PARALLEL_FIELD(matcher, MatcherParameters, target),
      PCL_PARALLEL_FIELD(matcher, MatcherParameters, max_correspondence_distance),
      PCL_PARALLEL_FIELD(matcher, MatcherParameters, final_correspondence_distance),
      PCL_PARALLEL_FIELD(matcher, MatcherParameters, max_iterations),
      PCL_PARALLEL_FIELD(matcher, MatcherParameters, transformation_epsilon),
      PCL_PARALLEL_FIELD(matcher, MatcherParameters, point_to_plane),
      PCL_PARALLEL_FIELD(matcher, MatcherParameters, normals_from_map),
      PCL_PARALLEL_FIELD(matcher, MatcherParameters, adaptive_threshold),
      PCL_PARALLEL_FIELD(matcher, MatcherParameters, motion_prior),
      PCL_PARALLEL_FIELD(matcher, MatcherParameters, map_distance),
      PCL_PARALLEL_FIELD(matcher, MatcherParameters, map_voxel_size),
      PCL_PARALLEL_FIELD(matcher, MatcherParameters, map_points_per_voxel),
      PCL_PARALLEL_FIELD(guess, PoseGuessParameters, guess_from_previous_scan),
      PCL_PARALLEL_FIELD(guess, PoseGuessParameters, speed_hypotheses),
      PCL_PARALLEL_FIELD(guess, PoseGuessParameters, pose_search),
      PCL_PARALLEL_FIELD(guess, PoseGuessParameters, up),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, enabled),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, distance),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, min_separation),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, min_overlap),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, overlap_distance),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, max_candidates),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, icp_distance),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, icp_iterations),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, icp_epsilon),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, max_drift),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, distribute_error),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, relax_each_loop),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, lum_iterations_per_loop),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, lum_distance),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, lum_final_distance),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, lum_iterations),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, lum_epsilon),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, lum_link_iterations),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, lum_point_to_plane),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, lum_queries_per_scan),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, sequence_constraints),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, sequence_cauchy_scale),
      PCL_PARALLEL_FIELD(loops, LoopClosureParameters, revisit_rounds),
  };
  return all;
}

#undef PCL_PARALLEL_FIELD

const char* const kStages[] = {"reduction", "deskew", "matcher", "guess", "loops"};

/** The stage dicts of Pipeline(...) over the defaults; unknown stages or keys raise. */
slam::Parameters
toParameters(const py::dict& stages, double median_range, const py::handle& threads)
{
  slam::Parameters p;
  for (const auto& [stage, value] : stages) {
    const std::string s = py::str(stage).cast<std::string>();
    if (std::find(std::begin(kStages), std::end(kStages), s) == std::end(kStages))
      throw std::invalid_argument(s + ": not a parameter (stages: reduction, deskew, matcher, "
                                      "guess, loops; and median_range, planar, threads)");
    if (value.is_none())
      continue;
    if (!py::isinstance<py::dict>(value))
      throw std::invalid_argument(s + ": expected a dict of its parameters");
    for (const auto& [key, v] : value.cast<py::dict>()) {
      const std::string k = py::str(key).cast<std::string>();
      const auto f = std::find_if(fields().begin(), fields().end(), [&](const Field& f) {
        return s == f.stage && k == f.name;
      });
      if (f == fields().end())
        throw std::invalid_argument(s + "." + k + ": no such parameter");
      f->set(p, v);
    }
  }
  if (std::isnan(median_range) || median_range < 0.0)
    throw std::invalid_argument("median_range: must be >= 0 (0: the first scan's)");
  p.median_range = median_range;
  p.num_threads = toThreads(threads);
  return p;
}

py::dict
toDict(const slam::Parameters& p)
{
  py::dict out;
  for (const char* stage : kStages)
    out[stage] = py::dict();
  for (const Field& f : fields())
    out[f.stage].cast<py::dict>()[f.name] = f.get(p);
  out["median_range"] = p.median_range;
  out["planar"] = p.planar;
  out["threads"] = p.num_threads;
  return out;
}

/** slam::Pipeline for Python: calls are serialised (the GIL is released while one runs). */
class Pipeline {
public:
  explicit Pipeline(const slam::Parameters& p)
      : pipeline_(new slam::Pipeline(p))
  {}

  py::object
  addScan(const py::handle& points,
          const py::handle& odometry,
          const py::handle& stamp,
          const py::handle& point_times)
  {
    const slam::Cloud::Ptr scan = toCloud(points, "points");
    std::optional<slam::Pose> odo;
    if (!odometry.is_none())
      odo = toPose(odometry, "odometry");
    std::optional<double> t;
    if (!stamp.is_none()) {
      if (!py::isinstance<py::float_>(stamp) && !py::isinstance<py::int_>(stamp))
        throw std::invalid_argument("stamp: expected a number in seconds");
      t = checkedNumber(stamp.cast<double>(), "stamp");
    }
    std::vector<double> times;
    if (!point_times.is_none())
      times = toValues(point_times, "point_times", static_cast<long>(scan->size()));
    const std::size_t k = withoutGil([&] {
      std::lock_guard<std::mutex> lock(mutex_);
      return pipeline_->addScan(*scan, odo, t, times);
    });
    const slam::Poses& poses = pipeline_->poses();
    return k < poses.size() ? py::object(fromPose(poses[k])) : py::object(py::none());
  }

  void
  finish()
  {
    withoutGil([&] {
      std::lock_guard<std::mutex> lock(mutex_);
      pipeline_->finish();
    });
  }

  py::array_t<float>
  map(double voxel) const
  {
    if (std::isnan(voxel))
      throw std::invalid_argument("voxel: NaN");
    return fromCloud(*withoutGil([&] {
      std::lock_guard<std::mutex> lock(mutex_);
      return pipeline_->size() == 0 ? slam::Cloud::Ptr(new slam::Cloud) : pipeline_->map(voxel);
    }));
  }

  py::dict
  consistency(bool front_end) const
  {
    const slam::RevisitConsistency c = withoutGil([&] {
      std::lock_guard<std::mutex> lock(mutex_);
      return pipeline_->consistency(front_end);
    });
    py::dict out;
    out["revisits"] = c.pairs;
    out["mean_conflicts"] = c.mean_conflicts;
    out["conflicting"] = c.conflicting;
    return out;
  }

  const slam::Pipeline&
  get() const
  {
    return *pipeline_;
  }

private:
  std::unique_ptr<slam::Pipeline> pipeline_;
  mutable std::mutex mutex_;
};

py::array_t<double>
posesOrEmpty(const slam::Poses& poses)
{
  return poses.empty() ? py::array_t<double>({py::ssize_t(0), py::ssize_t(4), py::ssize_t(4)})
                       : fromPoses(poses);
}

} // namespace

void
bindSlam(py::module_& m)
{
  m.def(
      "default_parameters",
      [] { return toDict(slam::Parameters()); },
      "slam::Parameters' defaults as Pipeline takes them: a dict per stage (0 lengths are "
      "automatic), median_range and threads.");
  py::class_<Pipeline>(m,
                       "Pipeline",
                       "The streaming SLAM pipeline (slam::Pipeline): scans one at a time, "
                       "pICP against a local map, loops closed by pLUM. Parameters: "
                       "Pipeline(reduction={...}, deskew={...}, matcher={...}, guess={...}, "
                       "loops={...}, median_range=0, planar=False, threads=None), keys as "
                       "slam::Parameters' fields (default_parameters()); automatic lengths "
                       "are resolved at the first scan.")
      .def(py::init([](const py::kwargs& kwargs) {
        py::dict stages;
        double median_range = 0.0;
        bool planar = false;
        py::object threads = py::none();
        for (const auto& [key, value] : kwargs) {
          const std::string k = key.cast<std::string>();
          if (k == "median_range")
            median_range = fromPython<double>(value, "median_range");
          else if (k == "planar")
            planar = fromPython<bool>(value, "planar");
          else if (k == "threads")
            threads = py::reinterpret_borrow<py::object>(value);
          else
            stages[key] = value;
        }
        slam::Parameters p = toParameters(stages, median_range, threads);
        p.planar = planar;
        return std::make_unique<Pipeline>(p);
      }))
      .def("add_scan",
           &Pipeline::addScan,
           py::arg("points"),
           py::arg("odometry") = py::none(),
           py::arg("stamp") = py::none(),
           py::arg("point_times") = py::none(),
           "Adds the next scan (scanner frame) with its odometry pose and time stamp (s), if "
           "known (every scan or none), and each point's time (deskewing). Returns its pose "
           "(4, 4), or None while it is held (deskewing: the first scan waits for the second).")
      .def(
          "finish", &Pipeline::finish, "The held scan, then a final pLUM over the whole graph.")
      .def("__len__", [](const Pipeline& p) { return p.get().size(); })
      .def_property_readonly(
          "poses",
          [](const Pipeline& p) { return posesOrEmpty(p.get().poses()); },
          "(M, 4, 4): the current best poses")
      .def_property_readonly(
          "front_end_poses",
          [](const Pipeline& p) { return posesOrEmpty(p.get().frontEndPoses()); },
          "(M, 4, 4): the front end's chained matches, without loop corrections")
      .def_property_readonly(
          "links",
          [](const Pipeline& p) {
            py::list out;
            for (const slam::Link& l : p.get().links())
              out.append(py::make_tuple(l.target, l.source, l.loop));
            return out;
          },
          "the pose graph's links: (target, source, loop) tuples")
      .def(
          "consistency",
          &Pipeline::consistency,
          py::arg("front_end") = false,
          "Where the scanner came back, how far the map disagrees with itself: each scan with "
          "its nearest earlier loop candidate, the larger share of either's points in space "
          "the other saw through. A dict: revisits (pairs), mean_conflicts, conflicting (pairs "
          "over 5 %: doubled walls). At the current poses, or the front end's.")
      .def_property_readonly("parameters",
                             [](const Pipeline& p) { return toDict(p.get().parameters()); })
      .def_property_readonly(
          "resolved_parameters",
          [](const Pipeline& p) {
            return p.get().size() == 0 ? py::object(py::none())
                                       : py::object(toDict(p.get().resolvedParameters()));
          },
          "the parameters with the automatic lengths set (None before the first scan)")
      .def("map",
           &Pipeline::map,
           py::arg("voxel") = 0.0,
           "(N, 3) float32: the kept (reduced) scans at the current poses, one centroid per "
           "voxel (<= 0: every point)");
}

} // namespace python
} // namespace pcl_parallel
