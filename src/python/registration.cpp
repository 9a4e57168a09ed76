/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "convert.h"

#include <pcl_parallel/registration/icp.h>
#include <pcl_parallel/registration/lum.h>
#include <pcl_parallel/slam/loop_closure.h>
#include <pcl_parallel/slam/parameters.h>
#include <pcl_parallel/slam/preprocess.h>

#include <cmath>
#include <limits>
#include <optional>
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

namespace pcl_parallel {
namespace python {

namespace {

using Icp = registration::ParallelIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ, float>;
using Lum = ParallelLUM<pcl::PointXYZ>;

/** PCL 1.13 has no getter for the iteration count: read the protected member through a
 *  pointer to the base's member (as test/common/synthetic_graph.h). */
struct IcpPeek : Icp {
  static int
  iterations(const Icp& icp)
  {
    return icp.*(&IcpPeek::nr_iterations_);
  }
};

struct IcpResult {
  Eigen::Matrix4d transformation = Eigen::Matrix4d::Identity();
  bool converged = false;
  double fitness = 0.0; ///< PCL's getFitnessScore: mean squared distance to the target
  int iterations = 0;
};

struct IcpOptions {
  double max_distance = std::numeric_limits<double>::infinity();
  int iterations = 50;
  double epsilon = 1e-8;
  bool point_to_plane = false;
  bool planar = false;
  registration::RobustKernel kernel;
  unsigned threads = 0;
};

registration::RobustKernel
toKernel(const py::handle& robust)
{
  registration::RobustKernel k;
  if (robust.is_none())
    return k;
  const char* usage = "robust: expected None or (\"huber\" | \"geman_mcclure\", scale)";
  if (!py::isinstance<py::tuple>(robust) || py::len(robust) != 2 ||
      !py::isinstance<py::str>(robust[py::int_(0)]))
    throw std::invalid_argument(usage);
  const std::string name = robust[py::int_(0)].cast<std::string>();
  if (name == "huber")
    k.type = registration::RobustKernel::Type::kHuber;
  else if (name == "geman_mcclure")
    k.type = registration::RobustKernel::Type::kGemanMcClure;
  else
    throw std::invalid_argument(std::string(usage) + ", got \"" + name + "\"");
  try {
    k.scale = robust[py::int_(1)].cast<double>();
  }
  catch (const py::cast_error&) {
    throw std::invalid_argument(usage);
  }
  checkedNumber(k.scale, "robust scale", true);
  return k;
}

IcpResult
runIcp(const slam::Cloud::Ptr& source,
       const slam::Cloud::Ptr& target,
       const Eigen::Matrix4d& init,
       const IcpOptions& o)
{
  Icp icp;
  icp.setNumberOfThreads(o.threads);
  icp.setInputSource(source);
  icp.setInputTarget(target);
  if (std::isfinite(o.max_distance)) // else PCL's default: no gate
    icp.setMaxCorrespondenceDistance(o.max_distance);
  icp.setMaximumIterations(o.iterations);
  icp.setTransformationEpsilon(o.epsilon);
  icp.setUsePointToPlane(o.point_to_plane);
  icp.setPlanar(o.planar);
  icp.setRobustKernel(o.kernel);
  slam::Cloud aligned;
  icp.alignDouble(aligned, init);
  IcpResult r;
  r.transformation = icp.getFinalTransformationDouble();
  r.converged = icp.hasConverged();
  r.fitness = icp.getFitnessScore();
  r.iterations = IcpPeek::iterations(icp);
  return r;
}

IcpResult
icpBinding(const py::handle& source,
           const py::handle& target,
           const py::handle& init,
           double max_distance,
           int iterations,
           const std::string& metric,
           const py::handle& robust,
           double epsilon,
           bool planar,
           const py::handle& threads)
{
  IcpOptions o;
  o.planar = planar;
  if (std::isnan(max_distance) || !(max_distance > 0.0))
    throw std::invalid_argument("max_distance: must be > 0 (inf: no gate)");
  o.max_distance = max_distance;
  if (iterations < 1)
    throw std::invalid_argument("iterations: must be >= 1, got " + std::to_string(iterations));
  o.iterations = iterations;
  if (metric != "point_to_point" && metric != "point_to_plane")
    throw std::invalid_argument("metric: \"point_to_point\" or \"point_to_plane\", got \"" +
                                metric + "\"");
  o.point_to_plane = metric == "point_to_plane";
  o.kernel = toKernel(robust);
  if (!std::isfinite(epsilon) || epsilon < 0.0)
    throw std::invalid_argument("epsilon: must be finite and >= 0");
  o.epsilon = epsilon;
  o.threads = toThreads(threads);
  const slam::Cloud::Ptr s = toCloud(source, "source"), t = toCloud(target, "target");
  const Eigen::Matrix4d guess =
      init.is_none() ? Eigen::Matrix4d::Identity() : toPose(init, "init");
  return withoutGil([&] { return runIcp(s, t, guess, o); });
}

/** Links (i, j) as the (K, 2) integer array `value`, each scan index below n. */
std::vector<std::pair<std::size_t, std::size_t>>
toLinks(const py::handle& value, std::size_t n)
{
  py::array a = py::array::ensure(value);
  if (!a || (a.dtype().kind() != 'i' && a.dtype().kind() != 'u'))
    throw std::invalid_argument("links: expected an integer array of shape (K, 2)");
  if (a.ndim() != 2 || a.shape(1) != 2 || a.shape(0) == 0)
    throw std::invalid_argument("links: expected shape (K, 2) with K >= 1");
  const auto ints = py::array_t<long long, py::array::forcecast>::ensure(a);
  auto v = ints.unchecked<2>();
  std::vector<std::pair<std::size_t, std::size_t>> links;
  for (py::ssize_t k = 0; k < v.shape(0); ++k) {
    const long long i = v(k, 0), j = v(k, 1);
    if (i < 0 || j < 0 || i >= static_cast<long long>(n) || j >= static_cast<long long>(n) ||
        i == j)
      throw std::invalid_argument("links: link " + std::to_string(k) + " (" +
                                  std::to_string(i) + ", " + std::to_string(j) +
                                  ") needs two distinct scans below " + std::to_string(n));
    links.emplace_back(static_cast<std::size_t>(i), static_cast<std::size_t>(j));
  }
  return links;
}

/** The default links: consecutive scans, and slam::loopCandidates for each scan (the
 *  pipeline's rule: closer than `distance`, `min_separation` apart, a path between). */
std::vector<std::pair<std::size_t, std::size_t>>
defaultLinks(const slam::Poses& poses, double distance, int min_separation, double range)
{
  std::vector<std::pair<std::size_t, std::size_t>> links;
  for (std::size_t j = 1; j < poses.size(); ++j) {
    links.emplace_back(j - 1, j);
    for (const std::uint32_t i :
         slam::loopCandidates(poses, j, distance, min_separation, range))
      links.emplace_back(i, j);
  }
  return links;
}

struct LumOptions {
  double distance = 0.0, final_distance = 0.0, epsilon = 0.0;
  int iterations = 20;
  bool point_to_plane = true;
  bool planar = false;
  unsigned threads = 0;
};

slam::Poses
runLum(const std::vector<slam::Cloud::Ptr>& scans,
       const slam::Poses& poses,
       const std::vector<std::pair<std::size_t, std::size_t>>& links,
       const LumOptions& o)
{
  Lum lum;
  lum.setNumberOfThreads(o.threads);
  for (std::size_t k = 0; k < scans.size(); ++k)
    lum.setPoseMatrix(lum.addPointCloud(scans[k], Eigen::Matrix4f::Identity().eval()),
                      poses[k]);
  for (const auto& [i, j] : links)
    lum.addLink(j, i); // source: the newer scan
  lum.setCorrespondenceDistanceSchedule(o.distance, o.final_distance, 0.7);
  lum.setMaxIterations(o.iterations);
  lum.setConvergenceThreshold(static_cast<float>(o.epsilon));
  lum.setPointToPlane(o.point_to_plane);
  lum.setPlanar(o.planar);
  lum.compute();
  slam::Poses out(scans.size());
  for (std::size_t k = 0; k < scans.size(); ++k)
    out[k] = lum.getPoseMatrix(k);
  return out;
}

/** lum(): the automatic lengths are the pipeline's (slam::resolve) for the first scan's
 *  median range. */
py::array_t<double>
lumBinding(const py::sequence& scan_list,
           const py::handle& pose_array,
           const py::handle& link_array,
           std::optional<double> max_distance,
           std::optional<double> final_distance,
           int iterations,
           std::optional<double> epsilon,
           bool point_to_plane,
           bool planar,
           std::optional<double> link_distance,
           int min_separation,
           const py::handle& threads)
{
  std::vector<slam::Cloud::Ptr> scans;
  for (std::size_t k = 0; k < scan_list.size(); ++k)
    scans.push_back(toCloud(scan_list[k], ("scans[" + std::to_string(k) + "]").c_str()));
  const slam::Poses poses = toPoses(pose_array, "poses");
  if (scans.size() < 2 || poses.size() != scans.size())
    throw std::invalid_argument(
        "scans, poses: need at least 2 scans and one pose per scan, got " +
        std::to_string(scans.size()) + " scans and " + std::to_string(poses.size()) + " poses");
  if (iterations < 1)
    throw std::invalid_argument("iterations: must be >= 1");
  if (min_separation < 1)
    throw std::invalid_argument("min_separation: must be >= 1");
  const double r = slam::medianRange(*scans[0]);
  const slam::Parameters p = slam::resolve(slam::Parameters(), r);
  LumOptions o;
  o.distance = checkedNumber(max_distance.value_or(p.loops.lum_distance), "max_distance", true);
  o.final_distance =
      checkedNumber(final_distance.value_or(std::min(o.distance, p.loops.lum_final_distance)),
                    "final_distance",
                    true);
  if (o.final_distance > o.distance)
    throw std::invalid_argument("final_distance: must be <= max_distance");
  o.epsilon = epsilon.value_or(p.loops.lum_epsilon);
  if (!std::isfinite(o.epsilon) || o.epsilon < 0.0)
    throw std::invalid_argument("epsilon: must be finite and >= 0");
  o.iterations = iterations;
  o.point_to_plane = point_to_plane;
  o.planar = planar;
  o.threads = toThreads(threads);
  const auto links =
      link_array.is_none()
          ? defaultLinks(
                poses,
                checkedNumber(link_distance.value_or(p.loops.distance), "link_distance", true),
                min_separation,
                r)
          : toLinks(link_array, scans.size());
  return fromPoses(withoutGil([&] { return runLum(scans, poses, links, o); }));
}

/** lum_links(): the links lum() makes when none are given. */
py::array_t<long long>
lumLinksBinding(const py::handle& pose_array,
                double link_distance,
                int min_separation,
                double range)
{
  const slam::Poses poses = toPoses(pose_array, "poses");
  checkedNumber(link_distance, "link_distance", true);
  checkedNumber(range, "range", true);
  if (min_separation < 1)
    throw std::invalid_argument("min_separation: must be >= 1");
  const auto links = defaultLinks(poses, link_distance, min_separation, range);
  py::array_t<long long> out({static_cast<py::ssize_t>(links.size()), py::ssize_t(2)});
  auto o = out.mutable_unchecked<2>();
  for (std::size_t k = 0; k < links.size(); ++k) {
    o(static_cast<py::ssize_t>(k), 0) = static_cast<long long>(links[k].first);
    o(static_cast<py::ssize_t>(k), 1) = static_cast<long long>(links[k].second);
  }
  return out;
}

} // namespace

void
bindRegistration(py::module_& m)
{
  py::class_<IcpResult>(m, "IcpResult", "What icp() found.")
      .def_property_readonly(
          "transformation",
          [](const IcpResult& r) { return fromPose(r.transformation); },
          "(4, 4) float64: target_point = T @ source_point")
      .def_readonly("converged", &IcpResult::converged)
      .def_readonly("fitness",
                    &IcpResult::fitness,
                    "mean squared distance of the aligned source points to their nearest "
                    "target points (PCL's getFitnessScore)")
      .def_readonly("iterations", &IcpResult::iterations)
      .def("__repr__", [](const IcpResult& r) {
        return "IcpResult(converged=" + std::string(r.converged ? "True" : "False") +
               ", fitness=" + std::to_string(r.fitness) +
               ", iterations=" + std::to_string(r.iterations) + ")";
      });
  m.def("icp",
        &icpBinding,
        py::arg("source"),
        py::arg("target"),
        py::arg("init") = py::none(),
        py::kw_only(),
        py::arg("max_distance") = std::numeric_limits<double>::infinity(),
        py::arg("iterations") = 50,
        py::arg("metric") = "point_to_point",
        py::arg("robust") = py::none(),
        py::arg("epsilon") = 1e-8,
        py::arg("planar") = false,
        py::arg("threads") = py::none(),
        "Parallel ICP (ParallelIterativeClosestPoint, alignDouble): the transform that moves "
        "source onto target, from init. max_distance: the correspondence gate (inf: none); "
        "epsilon: PCL's transformation epsilon; metric: \"point_to_point\" or "
        "\"point_to_plane\" (target normals estimated); robust: None or (\"huber\" | "
        "\"geman_mcclure\", scale); planar: steps in the x-y plane alone (x, y, yaw: 2D "
        "scans, z = 0).");
  m.def("lum",
        &lumBinding,
        py::arg("scans"),
        py::arg("poses"),
        py::arg("links") = py::none(),
        py::kw_only(),
        py::arg("max_distance") = py::none(),
        py::arg("final_distance") = py::none(),
        py::arg("iterations") = 20,
        py::arg("epsilon") = py::none(),
        py::arg("point_to_plane") = true,
        py::arg("planar") = false,
        py::arg("link_distance") = py::none(),
        py::arg("min_separation") = 5,
        py::arg("threads") = py::none(),
        "pLUM (ParallelLUM in pLUM mode): the (M, 4, 4) poses of the scans (each in its own "
        "frame) relaxed over the links, pairs searched within a gate shrinking x0.7 per "
        "iteration from max_distance to final_distance. links: (K, 2) scan indices; None: "
        "lum_links(poses, link_distance, min_separation, r). Automatic lengths (None) are "
        "the pipeline's for the first scan's median range r: max_distance r/2, "
        "final_distance r/10, epsilon r/2000, link_distance r. planar: updates in the x-y "
        "plane alone (2D scans, z = 0).");
  m.def("lum_links",
        &lumLinksBinding,
        py::arg("poses"),
        py::arg("link_distance"),
        py::arg("min_separation") = 5,
        py::arg("range") = 1.0,
        "The links lum() makes without links=: (j-1, j) for each scan j, and (i, j) for "
        "each slam::loopCandidates(poses, j, link_distance, min_separation, range).");
}

} // namespace python
} // namespace pcl_parallel
