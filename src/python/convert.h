/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

// The Python module's conversions between numpy arrays and the library's types, and its
// error policy: bad input is a std::invalid_argument naming the argument (ValueError), a
// file that cannot be read or written a FileError (OSError); never a crash.

#include <pcl_parallel/slam/types.h>

#include <cstddef>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace pcl_parallel {
namespace python {

namespace py = pybind11;

/** A file that cannot be read or written: OSError in Python, with the C++ message. */
struct FileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/** (N, 3) points as float32 rows `stride` floats apart: the array's own memory where it is
 *  float32 with aligned rows (no copy), else a converted copy held in `copy`. */
struct FloatPoints {
  const float* data = nullptr;
  std::size_t size = 0;
  std::size_t stride = 3; ///< floats from one point to the next
  std::vector<float> copy;
  py::object keep; ///< the array whose memory `data` points into
};

/** `value` as (N, 3) float32 or float64 points, N >= 1, all finite; throws
 *  std::invalid_argument naming `name` otherwise. */
FloatPoints
toFloatPoints(const py::handle& value, const char* name);

/** `value` as a cloud (always a copy: pcl::PointXYZ is padded to 16 bytes). */
slam::Cloud::Ptr
toCloud(const py::handle& value, const char* name);

/** A cloud as an (N, 3) float32 array. */
py::array_t<float>
fromCloud(const slam::Cloud& cloud);

/** `value` as a (4, 4) finite float array. */
Eigen::Matrix4d
toPose(const py::handle& value, const char* name);

/** `value` as an (M, 4, 4) finite float array (M >= 1). */
slam::Poses
toPoses(const py::handle& value, const char* name);

/** A pose as a (4, 4) float64 array. */
py::array_t<double>
fromPose(const Eigen::Matrix4d& pose);

/** Poses as an (M, 4, 4) float64 array. */
py::array_t<double>
fromPoses(const slam::Poses& poses);

/** A 1-D finite float array of `expected` values (any count when expected < 0). */
std::vector<double>
toValues(const py::handle& value, const char* name, long expected = -1);

/** The threads= argument: None is 0 (all cores); else an int in [0, kMaxThreads]. */
unsigned
toThreads(const py::handle& threads);

/** A finite number (or, with `positive`, finite and > 0); else std::invalid_argument. */
double
checkedNumber(double value, const char* name, bool positive = false);

/** A path argument: str or os.PathLike. */
std::string
toPath(const py::handle& value, const char* name);

/** f() with the GIL released (it must not touch Python objects); std::runtime_error
 *  from it becomes FileError when `files`. */
template <typename F>
auto
withoutGil(F&& f, bool files = false)
{
  py::gil_scoped_release release;
  if (!files)
    return f();
  try {
    return f();
  }
  catch (const std::invalid_argument&) {
    throw;
  }
  catch (const std::runtime_error& e) {
    throw FileError(e.what());
  }
}

/** The module's parts, one per concern. */
///@{
void
bindErrors(py::module_& m);
void
bindRegistration(py::module_& m);
void
bindSearch(py::module_& m);
void
bindSlam(py::module_& m);
void
bindIo(py::module_& m);
///@}

} // namespace python
} // namespace pcl_parallel
