/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "convert.h"

#include <pcl_parallel/evaluation/report.h>
#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/io/scan_directory.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/io/uos.h>
#include <pcl_parallel/sim/scan_set_writer.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <optional>
#include <pybind11/stl.h>

namespace pcl_parallel {
namespace python {

namespace {

namespace ev = evaluation;

using Scan = pcl::PointCloud<pcl::PointXYZ>::Ptr;

/** Points (and, when asked, the point times or None) as read_scan returns them. */
py::object
scanResult(const Scan& scan, const std::vector<double>& times, bool with_times)
{
  py::array_t<float> points = fromCloud(*scan);
  if (!with_times)
    return std::move(points);
  return py::make_tuple(points,
                        times.empty()
                            ? py::object(py::none())
                            : py::object(py::array_t<double>(
                                  static_cast<py::ssize_t>(times.size()), times.data())));
}

void
checkRange(double min_range, double max_range)
{
  if (std::isnan(min_range) || std::isnan(max_range) || min_range < 0.0 ||
      max_range < min_range)
    throw std::invalid_argument("min_range, max_range: need 0 <= min_range <= max_range");
}

py::object
readScan(const py::handle& path_value,
         const std::optional<std::string>& format,
         double min_range,
         double max_range,
         bool point_times)
{
  const std::string path = toPath(path_value, "path");
  checkRange(min_range, max_range);
  std::string ext;
  if (format) {
    ext = io::scanFormatFromName(*format);
    if (ext.empty())
      throw std::invalid_argument("format: unknown scan format \"" + *format +
                                  "\" (3d, xyz, txt, bin, pcd, ply)");
  }
  std::vector<double> times;
  const Scan scan = withoutGil(
      [&] {
        if (ext.empty())
          return io::loadScan(path, min_range, max_range, &times);
        if (ext == "3d")
          return io::loadUosScan(path, min_range, max_range);
        if (ext == "bin")
          return io::loadKittiScan(path, min_range, max_range);
        if (ext == "pcd")
          return io::loadPcdScan(path, min_range, max_range, &times);
        if (ext == "ply")
          return io::loadPlyScan(path, min_range, max_range, &times);
        return io::loadXyzScan(path, min_range, max_range);
      },
      true);
  return scanResult(scan, times, point_times);
}

py::object
readPoses(const py::handle& path_value, bool with_timestamps, double frames_unit)
{
  const std::string path = toPath(path_value, "path");
  checkedNumber(frames_unit, "frames_unit", true);
  const io::Trajectory t =
      withoutGil([&] { return io::loadTrajectory(path, frames_unit); }, true);
  py::array_t<double> poses =
      t.poses.empty() ? py::array_t<double>({py::ssize_t(0), py::ssize_t(4), py::ssize_t(4)})
                      : fromPoses(t.poses);
  if (!with_timestamps)
    return std::move(poses);
  return py::make_tuple(
      poses,
      t.timestamps.empty()
          ? py::object(py::none())
          : py::object(py::array_t<double>(static_cast<py::ssize_t>(t.timestamps.size()),
                                           t.timestamps.data())));
}

void
writePoses(const py::handle& path_value,
           const py::handle& pose_array,
           const std::string& format,
           const py::handle& timestamps,
           double frames_unit)
{
  const std::string path = toPath(path_value, "path");
  const slam::Poses poses = toPoses(pose_array, "poses");
  checkedNumber(frames_unit, "frames_unit", true);
  std::vector<double> stamps;
  if (!timestamps.is_none())
    stamps = toValues(timestamps, "timestamps", static_cast<long>(poses.size()));
  if (format != "kitti" && format != "tum" && format != "frames")
    throw std::invalid_argument("format: \"kitti\", \"tum\" or \"frames\", got \"" + format +
                                "\"");
  withoutGil(
      [&] {
        if (format == "kitti")
          io::writeKittiPoses(path, poses);
        else if (format == "tum")
          io::writeTumTrajectory(path, poses, stamps);
        else
          io::writeFrames(path, poses, frames_unit);
      },
      true);
}

/** A trajectory argument of evaluate(): a file, or (M, 4, 4) poses paired by index. */
io::Trajectory
toTrajectory(const py::handle& value, const char* name, double frames_unit, std::string& path)
{
  if (py::isinstance<py::str>(value) || py::hasattr(value, "__fspath__")) {
    path = toPath(value, name);
    return withoutGil([&] { return io::loadTrajectory(path, frames_unit); }, true);
  }
  path = std::string("<") + name + " array>";
  io::Trajectory t;
  t.poses = toPoses(value, name);
  return t;
}

py::object
evaluate(const py::handle& estimate,
         const py::handle& truth,
         const std::string& align,
         const std::string& lengths,
         std::size_t step,
         std::size_t delta,
         double max_diff,
         double frames_unit,
         bool truncate)
{
  ev::FileEvaluationOptions o;
  o.evaluation.alignment = ev::alignmentFromString(align);
  o.evaluation.kitti_lengths = ev::kittiLengthsFromString(lengths);
  if (step == 0 || delta == 0)
    throw std::invalid_argument("step, delta: must be >= 1");
  o.evaluation.kitti_step = step;
  o.evaluation.rpe_delta = delta;
  if (std::isnan(max_diff) || max_diff < 0.0)
    throw std::invalid_argument("max_diff: must be >= 0");
  o.max_diff = max_diff;
  o.frames_unit = checkedNumber(frames_unit, "frames_unit", true);
  o.truncate = truncate;
  ev::FileEvaluation e;
  e.estimate = toTrajectory(estimate, "estimate", frames_unit, e.estimate_path);
  e.truth = toTrajectory(truth, "truth", frames_unit, e.truth_path);
  const std::string json = withoutGil([&] {
    try {
      const ev::PairedTrajectories paired = ev::pairTrajectories(
          e.estimate, e.estimate_path, e.truth, e.truth_path, o.max_diff, o.truncate);
      e.association = paired.association;
      e.errors = ev::evaluateTrajectory(paired.estimate, paired.truth, o.evaluation);
    }
    catch (const std::runtime_error& error) { // trajectories that cannot be paired: bad input
      throw std::invalid_argument(error.what());
    }
    return ev::toJson(e);
  });
  return py::module_::import("json").attr("loads")(json);
}

py::dict
simulate(const std::string& preset,
         const py::handle& directory,
         std::uint32_t seed,
         int max_scans,
         int stride,
         int beams,
         const std::string& format,
         const py::handle& threads)
{
  const std::string dir = toPath(directory, "directory");
  sim::PresetOptions o;
  o.seed = seed;
  o.max_scans = max_scans;
  o.stride = stride;
  o.beams = beams;
  o.num_threads = toThreads(threads);
  const sim::ScanSetFormat f = sim::scanSetFormatFromString(format);
  const sim::ScanSetSummary s =
      withoutGil([&] { return sim::simulateToDirectory(preset, o, dir, f); }, true);
  py::dict out;
  out["scans"] = s.scans;
  out["points"] = s.points;
  out["moving"] = s.moving;
  return out;
}

/** io::ScanDirectory with its reader, for streaming a directory as pcl_pslam reads it. */
struct ScanDirectory {
  io::ScanDirectory dir;

  py::object
  read(long k, bool point_times) const
  {
    if (k < 0 || k >= static_cast<long>(dir.size()))
      throw py::index_error("scan " + std::to_string(k) + " not in [0, " +
                            std::to_string(dir.size()) + ")");
    std::vector<double> times;
    const Scan scan = withoutGil(
        [&] {
          return io::readScan(dir, static_cast<std::size_t>(k), point_times ? &times : nullptr);
        },
        true);
    return scanResult(scan, times, point_times);
  }
};

ScanDirectory
openDirectory(const py::handle& directory,
              const py::handle& poses_file,
              const py::handle& times_file,
              const std::optional<std::string>& format,
              int first,
              int last,
              double min_range,
              double max_range,
              std::optional<double> scale,
              std::optional<int> up,
              bool no_poses)
{
  io::ScanDirectoryOptions o;
  o.dir = toPath(directory, "directory");
  if (!poses_file.is_none())
    o.poses_file = toPath(poses_file, "poses_file");
  if (!times_file.is_none())
    o.times_file = toPath(times_file, "times_file");
  o.format = format.value_or("");
  o.first = first;
  o.last = last;
  checkRange(min_range, max_range);
  o.min_range = min_range;
  o.max_range = max_range;
  if (scale)
    o.scale = checkedNumber(*scale, "scale", true);
  if (up && (*up < 0 || *up > 2))
    throw std::invalid_argument("up: the axis 0, 1 or 2 (x, y, z)");
  o.up = up.value_or(-1);
  o.no_poses = no_poses;
  return ScanDirectory{withoutGil(
      [&] {
        // openScanDirectory calls a missing directory or log a usage error; here it is a
        // file's (OSError)
        if (std::error_code ec; !std::filesystem::exists(o.dir, ec))
          throw std::runtime_error(o.dir + ": no such directory or log");
        return io::openScanDirectory(o);
      },
      true)};
}

void
bindScanDirectory(py::module_& m)
{
  py::class_<ScanDirectory>(
      m,
      "ScanDirectory",
      "A directory of scans, or a 2D laser log (.clf, .clf.bz2), as pcl_pslam run reads it "
      "(io::openScanDirectory): files, odometry, time stamps; read(k) "
      "gives scan k in metres within the range limits.")
      .def(py::init(&openDirectory),
           py::arg("directory"),
           py::kw_only(),
           py::arg("poses_file") = py::none(),
           py::arg("times_file") = py::none(),
           py::arg("format") = py::none(),
           py::arg("first") = 0,
           py::arg("last") = -1,
           py::arg("min_range") = 0.0,
           py::arg("max_range") = std::numeric_limits<double>::infinity(),
           py::arg("scale") = py::none(),
           py::arg("up") = py::none(),
           py::arg("no_poses") = false)
      .def("__len__", [](const ScanDirectory& d) { return d.dir.size(); })
      .def("read", &ScanDirectory::read, py::arg("k"), py::arg("point_times") = false)
      .def_property_readonly("files", [](const ScanDirectory& d) { return d.dir.files; })
      .def_property_readonly("numbers", [](const ScanDirectory& d) { return d.dir.numbers; })
      .def_property_readonly("odometry",
                             [](const ScanDirectory& d) {
                               return d.dir.odometry ? py::object(fromPoses(d.dir.initial))
                                                     : py::object(py::none());
                             })
      .def_property_readonly("stamps",
                             [](const ScanDirectory& d) {
                               return d.dir.has_stamps ? py::cast(d.dir.stamps)
                                                       : py::object(py::none());
                             })
      .def_property_readonly("format", [](const ScanDirectory& d) { return d.dir.format; })
      .def_property_readonly("scale", [](const ScanDirectory& d) { return d.dir.scale; })
      .def_property_readonly(
          "up",
          [](const ScanDirectory& d) {
            Eigen::Vector3d u = Eigen::Vector3d::Zero();
            u[d.dir.up] = 1.0;
            return py::make_tuple(u.x(), u.y(), u.z());
          },
          "the vertical axis as a vector (Pipeline's guess={\"up\": ...})")
      .def_property_readonly(
          "planar",
          [](const ScanDirectory& d) { return d.dir.planar; },
          "True for a 2D scanner's scans (a log, or scans in their x-y plane): Pipeline's "
          "planar=..., as pcl_pslam run maps them");
}

} // namespace

void
bindIo(py::module_& m)
{
  m.def("read_scan",
        &readScan,
        py::arg("path"),
        py::arg("format") = py::none(),
        py::kw_only(),
        py::arg("min_range") = 0.0,
        py::arg("max_range") = std::numeric_limits<double>::infinity(),
        py::arg("point_times") = false,
        "A scan file (.3d .xyz .txt .bin .pcd .ply; format= overrides the extension) as "
        "(N, 3) float32 in the file's units, non-finite and origin points dropped; with "
        "point_times=True, (points, times or None).");
  m.def("read_poses",
        &readPoses,
        py::arg("path"),
        py::kw_only(),
        py::arg("with_timestamps") = false,
        py::arg("frames_unit") = io::kFramesUnit,
        "A KITTI, TUM or 3DTK .frames trajectory (format detected) as (M, 4, 4); with "
        "with_timestamps=True, (poses, timestamps or None).");
  m.def("write_poses",
        &writePoses,
        py::arg("path"),
        py::arg("poses"),
        py::kw_only(),
        py::arg("format") = "kitti",
        py::arg("timestamps") = py::none(),
        py::arg("frames_unit") = io::kFramesUnit,
        "Writes (M, 4, 4) poses as \"kitti\", \"tum\" or \"frames\" (atomically; numbers "
        "written to round-trip exactly).");
  m.def("evaluate",
        &evaluate,
        py::arg("estimate"),
        py::arg("truth"),
        py::kw_only(),
        py::arg("align") = "se3",
        py::arg("lengths") = "auto",
        py::arg("step") = 10,
        py::arg("delta") = 1,
        py::arg("max_diff") = 0.01,
        py::arg("frames_unit") = io::kFramesUnit,
        py::arg("truncate") = false,
        "ATE and RPE of an estimate against a reference, each a trajectory file or (M, 4, 4) "
        "poses: the dict `pcl_pslam evaluate --json` prints (same options).");
  m.def("preset_names", &sim::presetNames, "The simulator's presets.");
  m.def("simulate",
        &simulate,
        py::arg("preset"),
        py::arg("directory"),
        py::kw_only(),
        py::arg("seed") = 1,
        py::arg("max_scans") = -1,
        py::arg("stride") = 1,
        py::arg("beams") = 0,
        py::arg("format") = "auto",
        py::arg("threads") = py::none(),
        "Simulates a preset into a directory as `pcl_pslam simulate` (scans, odometry, "
        "ground_truth.txt); returns {scans, points, moving}.");
  bindScanDirectory(m);
}

} // namespace python
} // namespace pcl_parallel
