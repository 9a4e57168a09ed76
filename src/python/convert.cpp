/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "convert.h"

#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/parallel.h>

#include <cmath>
#include <cstdint>
#include <cstring>

namespace pcl_parallel {
namespace python {

namespace {

std::string
prefix(const char* name)
{
  return std::string(name) + ": ";
}

/** `value` as a numpy array of float32 or float64 with `ndim` dimensions. */
py::array
floatArray(const py::handle& value, const char* name, int ndim, const std::string& shape)
{
  if (value.is_none())
    throw std::invalid_argument(prefix(name) + "expected an array of shape " + shape +
                                ", got None");
  py::array a = py::array::ensure(value);
  if (!a)
    throw std::invalid_argument(prefix(name) + "expected an array of shape " + shape);
  const char kind = a.dtype().kind();
  if (kind != 'f' || (a.itemsize() != 4 && a.itemsize() != 8))
    throw std::invalid_argument(prefix(name) + "dtype " +
                                py::str(a.dtype()).cast<std::string>() +
                                " not supported: float32 or float64");
  if (!a.dtype().attr("isnative").cast<bool>()) // element() reads native byte order
    a = py::array::ensure(a.attr("astype")(a.dtype().attr("newbyteorder")("=")));
  if (a.ndim() != ndim)
    throw std::invalid_argument(prefix(name) + "expected shape " + shape + ", got " +
                                std::to_string(a.ndim()) + " dimensions");
  return a;
}

std::string
shapeText(const py::array& a)
{
  std::string s = "(";
  for (py::ssize_t d = 0; d < a.ndim(); ++d)
    s += (d ? ", " : "") + std::to_string(a.shape(d));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

/** Element at byte offset `at` of `a` as a double (memcpy: numpy may hand out unaligned
 *  views). */
double
element(const py::array& a, py::ssize_t at)
{
  const char* p = static_cast<const char*>(a.data()) + at;
  if (a.itemsize() == 4) {
    float f;
    std::memcpy(&f, p, 4);
    return f;
  }
  double d;
  std::memcpy(&d, p, 8);
  return d;
}

/** The (N, 3) array `a`'s values through `put(i, j, v)`, each checked finite. */
template <typename Put>
void
forEachPointValue(const py::array& a, const char* name, Put&& put)
{
  const py::ssize_t n = a.shape(0), s0 = a.strides(0), s1 = a.strides(1);
  for (py::ssize_t i = 0; i < n; ++i)
    for (py::ssize_t j = 0; j < 3; ++j) {
      const double v = element(a, i * s0 + j * s1);
      if (!std::isfinite(v))
        throw std::invalid_argument(prefix(name) + "point " + std::to_string(i) +
                                    " is not finite");
      put(i, j, v);
    }
}

py::array
pointArray(const py::handle& value, const char* name)
{
  py::array a = floatArray(value, name, 2, "(N, 3)");
  if (a.shape(1) != 3)
    throw std::invalid_argument(prefix(name) + "expected shape (N, 3), got " + shapeText(a));
  if (a.shape(0) == 0)
    throw std::invalid_argument(prefix(name) + "no points (shape " + shapeText(a) + ")");
  return a;
}

} // namespace

FloatPoints
toFloatPoints(const py::handle& value, const char* name)
{
  const py::array a = pointArray(value, name);
  FloatPoints p;
  p.size = static_cast<std::size_t>(a.shape(0));
  const auto address = reinterpret_cast<std::uintptr_t>(a.data());
  const bool direct = a.itemsize() == 4 && a.strides(1) == 4 && a.strides(0) > 0 &&
                      a.strides(0) % 4 == 0 && address % alignof(float) == 0;
  if (direct) { // the float32 rows as they are: checked, not copied
    p.data = static_cast<const float*>(a.data());
    p.stride = static_cast<std::size_t>(a.strides(0) / 4);
    forEachPointValue(a, name, [](py::ssize_t, py::ssize_t, double) {});
    p.keep = a;
    return p;
  }
  p.copy.resize(3 * p.size);
  forEachPointValue(a, name, [&](py::ssize_t i, py::ssize_t j, double v) {
    p.copy[3 * static_cast<std::size_t>(i) + static_cast<std::size_t>(j)] =
        static_cast<float>(v);
  });
  p.data = p.copy.data();
  return p;
}

slam::Cloud::Ptr
toCloud(const py::handle& value, const char* name)
{
  const py::array a = pointArray(value, name);
  slam::Cloud::Ptr cloud(new slam::Cloud);
  cloud->resize(static_cast<std::size_t>(a.shape(0)));
  forEachPointValue(a, name, [&](py::ssize_t i, py::ssize_t j, double v) {
    (*cloud)[static_cast<std::size_t>(i)].data[j] = static_cast<float>(v);
  });
  cloud->width = static_cast<std::uint32_t>(cloud->size());
  cloud->height = 1;
  cloud->is_dense = true;
  return cloud;
}

py::array_t<float>
fromCloud(const slam::Cloud& cloud)
{
  py::array_t<float> out({static_cast<py::ssize_t>(cloud.size()), py::ssize_t(3)});
  auto o = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < cloud.size(); ++i)
    for (int j = 0; j < 3; ++j)
      o(static_cast<py::ssize_t>(i), j) = cloud[i].data[j];
  return out;
}

Eigen::Matrix4d
toPose(const py::handle& value, const char* name)
{
  const py::array a = floatArray(value, name, 2, "(4, 4)");
  if (a.shape(0) != 4 || a.shape(1) != 4)
    throw std::invalid_argument(prefix(name) + "expected shape (4, 4), got " + shapeText(a));
  Eigen::Matrix4d pose;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) {
      pose(r, c) = element(a, r * a.strides(0) + c * a.strides(1));
      if (!std::isfinite(pose(r, c)))
        throw std::invalid_argument(prefix(name) + "not finite");
    }
  if (const std::string problem = io::poseProblem(pose); !problem.empty())
    throw std::invalid_argument(prefix(name) + "the pose " + problem);
  return pose;
}

slam::Poses
toPoses(const py::handle& value, const char* name)
{
  const py::array a = floatArray(value, name, 3, "(M, 4, 4)");
  if (a.shape(1) != 4 || a.shape(2) != 4 || a.shape(0) == 0)
    throw std::invalid_argument(prefix(name) + "expected shape (M, 4, 4) with M >= 1, got " +
                                shapeText(a));
  slam::Poses poses(static_cast<std::size_t>(a.shape(0)));
  for (py::ssize_t k = 0; k < a.shape(0); ++k)
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) {
        const double v = element(a, k * a.strides(0) + r * a.strides(1) + c * a.strides(2));
        if (!std::isfinite(v))
          throw std::invalid_argument(prefix(name) + "pose " + std::to_string(k) +
                                      " is not finite");
        poses[static_cast<std::size_t>(k)](r, c) = v;
      }
  for (std::size_t k = 0; k < poses.size(); ++k)
    if (const std::string problem = io::poseProblem(poses[k]); !problem.empty())
      throw std::invalid_argument(prefix(name) + "pose " + std::to_string(k) + " " + problem);
  return poses;
}

py::array_t<double>
fromPose(const Eigen::Matrix4d& pose)
{
  py::array_t<double> out({4, 4});
  auto o = out.mutable_unchecked<2>();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      o(r, c) = pose(r, c);
  return out;
}

py::array_t<double>
fromPoses(const slam::Poses& poses)
{
  py::array_t<double> out(
      {static_cast<py::ssize_t>(poses.size()), py::ssize_t(4), py::ssize_t(4)});
  auto o = out.mutable_unchecked<3>();
  for (std::size_t k = 0; k < poses.size(); ++k)
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c)
        o(static_cast<py::ssize_t>(k), r, c) = poses[k](r, c);
  return out;
}

std::vector<double>
toValues(const py::handle& value, const char* name, long expected)
{
  const py::array a = floatArray(value, name, 1, "(N,)");
  if (expected >= 0 && a.shape(0) != expected)
    throw std::invalid_argument(prefix(name) + "expected " + std::to_string(expected) +
                                " values, got " + std::to_string(a.shape(0)));
  std::vector<double> values(static_cast<std::size_t>(a.shape(0)));
  for (py::ssize_t i = 0; i < a.shape(0); ++i) {
    values[static_cast<std::size_t>(i)] = element(a, i * a.strides(0));
    if (!std::isfinite(values[static_cast<std::size_t>(i)]))
      throw std::invalid_argument(prefix(name) + "value " + std::to_string(i) +
                                  " is not finite");
  }
  return values;
}

unsigned
toThreads(const py::handle& threads)
{
  if (threads.is_none())
    return 0;
  if (!py::isinstance<py::int_>(threads) || py::isinstance<py::bool_>(threads))
    throw std::invalid_argument("threads: expected None or an int");
  const long long n = threads.cast<long long>();
  if (n < 0 || n > static_cast<long long>(kMaxThreads))
    throw std::invalid_argument("threads: " + std::to_string(n) + " not in [0, " +
                                std::to_string(kMaxThreads) + "] (0: all cores)");
  return static_cast<unsigned>(n);
}

double
checkedNumber(double value, const char* name, bool positive)
{
  if (!std::isfinite(value) || (positive && !(value > 0.0)))
    throw std::invalid_argument(prefix(name) + std::to_string(value) + " is not " +
                                (positive ? "a positive finite number" : "finite"));
  return value;
}

std::string
toPath(const py::handle& value, const char* name)
{
  try {
    return py::module_::import("os").attr("fspath")(value).cast<std::string>();
  }
  catch (const py::error_already_set&) {
    throw std::invalid_argument(prefix(name) + "expected a str or os.PathLike path");
  }
  catch (const py::cast_error&) { // bytes paths
    throw std::invalid_argument(prefix(name) + "expected a str or os.PathLike path");
  }
}

void
bindErrors(py::module_& m)
{
  (void)m;
  // std::invalid_argument is ValueError by pybind11's own translation.
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p)
        std::rethrow_exception(p);
    }
    catch (const FileError& e) {
      PyErr_SetString(PyExc_OSError, e.what());
    }
  });
}

} // namespace python
} // namespace pcl_parallel
