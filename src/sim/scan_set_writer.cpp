/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "../io/file_names.h"

#include <pcl_parallel/io/pose_files.h>
#include <pcl_parallel/sim/scan_set_writer.h>

#include <Eigen/Geometry>

#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>

namespace pcl_parallel {
namespace sim {

namespace fs = std::filesystem;

namespace {

/** A file written to "NAME.tmp" and renamed to NAME on commit(); removed if not. */
class AtomicFile {
public:
  explicit AtomicFile(std::string path)
      : path_(std::move(path))
      , tmp_(path_ + ".tmp")
  {
    file_ = std::fopen(tmp_.c_str(), "wb");
    if (!file_)
      fail("cannot open for writing");
  }
  ~AtomicFile()
  {
    if (file_) {
      std::fclose(file_);
      std::remove(tmp_.c_str());
    }
  }
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile&
  operator=(const AtomicFile&) = delete;

  void
  write(const void* data, std::size_t bytes)
  {
    if (bytes > 0 && std::fwrite(data, 1, bytes, file_) != bytes)
      fail("write failed (disk full?)");
  }
  void
  write(const std::string& s)
  {
    write(s.data(), s.size());
  }
  void
  commit()
  {
    const int rc = std::fclose(file_);
    file_ = nullptr;
    std::error_code ec;
    if (rc != 0)
      std::remove(tmp_.c_str()), fail("write failed on close (disk full?)");
    fs::rename(tmp_, path_, ec);
    if (ec)
      std::remove(tmp_.c_str()), fail("cannot rename " + tmp_ + ": " + ec.message());
  }

private:
  [[noreturn]] void
  fail(const std::string& what) const
  {
    throw std::runtime_error("pcl_parallel::sim: " + path_ + ": " + what);
  }
  std::string path_, tmp_;
  std::FILE* file_ = nullptr;
};

/** Appends a number: fixed with `digits` decimals, or (digits < 0) the shortest form
 *  that reads back exactly. Locale-independent (std::to_chars). */
void
append(std::string& out, double v, int digits = -1)
{
  if (digits >= 0 && std::abs(v) < 0.5 * std::pow(10.0, -digits))
    v = 0.0; // no "-0.0000"
  else if (v == 0.0)
    v = 0.0; // no "-0"
  char buf[64];
  const auto r =
      digits < 0 ? std::to_chars(buf, buf + sizeof(buf), v)
                 : std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::fixed, digits);
  out.append(buf, r.ptr);
}

std::string
numbered(const char* pattern, std::size_t i)
{
  char name[64];
  std::snprintf(name, sizeof(name), pattern, static_cast<unsigned>(i));
  return name;
}

} // namespace

Eigen::Matrix3d
uosAxes()
{
  Eigen::Matrix3d c;
  c << 0, -1, 0, //
      0, 0, 1,   //
      1, 0, 0;
  return c;
}

Eigen::Matrix4d
toUosFrame(const Eigen::Matrix4d& pose)
{
  const Eigen::Matrix3d c = uosAxes();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = c * pose.topLeftCorner<3, 3>() * c.transpose();
  m.topRightCorner<3, 1>() = c * pose.topRightCorner<3, 1>();
  return m;
}

namespace {

/** The scans as 3DTK uos files in 3DTK's axes: scanNNN.3d in centimetres and scanNNN.pose
 *  from the odometry; `truth` is turned into the same axes. */
void
writeUosScans(const SimulatedScanSet& set,
              const fs::path& root,
              std::vector<Eigen::Matrix4d>& truth)
{
  const std::size_t n = set.scans.size();
  if (n > 1000)
    throw std::invalid_argument("pcl_parallel::sim: writeScanSet: 3DTK's scanNNN names hold "
                                "at most 1000 scans, the set has " +
                                std::to_string(n));
  const Eigen::Matrix3d c = uosAxes();
  std::string text;
  for (std::size_t i = 0; i < n; ++i) {
    text.clear();
    text.reserve(set.scans[i]->size() * 32);
    for (const auto& p : *set.scans[i]) {
      // Centimetres in 3DTK's axes; 1e-4 cm is far below float resolution at range.
      const Eigen::Vector3d q = 100.0 * (c * p.getVector3fMap().cast<double>());
      append(text, q.x(), 4), text += ' ';
      append(text, q.y(), 4), text += ' ';
      append(text, q.z(), 4), text += '\n';
    }
    AtomicFile scan((root / numbered("scan%03u.3d", i)).string());
    scan.write(text);
    scan.commit();

    // Odometry as a 3DTK .pose: R = Rx(a) Ry(b) Rz(c), which Eigen's eulerAngles(0, 1, 2)
    // decomposes.
    const Eigen::Matrix4d odo = toUosFrame(set.odometry[i]);
    const Eigen::Vector3d euler =
        odo.topLeftCorner<3, 3>().eulerAngles(0, 1, 2) * (180.0 / M_PI);
    std::string pose;
    for (int k = 0; k < 3; ++k)
      append(pose, 100.0 * odo(k, 3)), pose += k < 2 ? ' ' : '\n';
    for (int k = 0; k < 3; ++k)
      append(pose, euler(k)), pose += k < 2 ? ' ' : '\n';
    AtomicFile pf((root / numbered("scan%03u.pose", i)).string());
    pf.write(pose);
    pf.commit();
    truth[i] = toUosFrame(set.truth[i]);
  }
}

/** Scan i's file bytes: KITTI .bin (x y z and intensity 0) or binary PCD (x y z and t, ns
 *  from the sweep's start, 0 without point times), little-endian on any host. */
void
scanBytes(const SimulatedScanSet& set,
          std::size_t i,
          bool pcd,
          std::vector<unsigned char>& bytes)
{
  const auto put = [&](std::uint32_t u) {
    for (int b = 0; b < 4; ++b)
      bytes.push_back(static_cast<unsigned char>(u >> (8 * b)));
  };
  const auto bits = [](float v) {
    std::uint32_t u;
    std::memcpy(&u, &v, 4);
    return u;
  };
  const auto& scan = *set.scans[i];
  bytes.clear();
  bytes.reserve(16 * scan.size() + 256);
  if (pcd) {
    const std::string size = std::to_string(scan.size());
    const std::string header =
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z t\n"
        "SIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH " +
        size + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + size + "\nDATA binary\n";
    bytes.insert(bytes.end(), header.begin(), header.end());
  }
  const bool timed = pcd && !set.point_times.empty();
  if (timed && set.point_times[i].size() != scan.size())
    throw std::invalid_argument("pcl_parallel::sim: writeScanSet: scan " + std::to_string(i) +
                                " has " + std::to_string(set.point_times[i].size()) +
                                " point times for " + std::to_string(scan.size()) + " points");
  for (std::size_t k = 0; k < scan.size(); ++k) {
    const auto& p = scan[k];
    put(bits(p.x)), put(bits(p.y)), put(bits(p.z));
    if (!pcd)
      put(bits(0.0f)); // intensity
    else
      put(timed ? static_cast<std::uint32_t>(
                      std::llround(1e9 * set.scanner.sweep_period * set.point_times[i][k]))
                : 0u);
  }
}

/** The scans as KITTI .bin or PCD files, the odometry and the scans' times. */
void
writeKittiScans(const SimulatedScanSet& set, const fs::path& root, bool pcd)
{
  const std::size_t n = set.scans.size();
  std::vector<unsigned char> bytes;
  for (std::size_t i = 0; i < n; ++i) {
    scanBytes(set, i, pcd, bytes);
    AtomicFile file((root / numbered(pcd ? "%06u.pcd" : "%06u.bin", i)).string());
    file.write(bytes.data(), bytes.size());
    file.commit();
  }
  io::writeKittiPoses((root / "odometry.txt").string(), set.odometry);
  std::string times;
  for (std::size_t i = 0; i < n; ++i)
    append(times, set.timestamps.empty() ? 0.1 * static_cast<double>(i) : set.timestamps[i]),
        times += '\n';
  AtomicFile tf((root / "times.txt").string());
  tf.write(times);
  tf.commit();
}

} // namespace

void
writeScanSet(const SimulatedScanSet& set, const std::string& dir, ScanSetFormat format)
{
  const std::size_t n = set.scans.size();
  if (set.truth.size() != n || set.odometry.size() != n ||
      (!set.point_times.empty() && set.point_times.size() != n) ||
      (!set.timestamps.empty() && set.timestamps.size() != n))
    throw std::invalid_argument("pcl_parallel::sim: writeScanSet: " + std::to_string(n) +
                                " scans but " + std::to_string(set.truth.size()) +
                                " true and " + std::to_string(set.odometry.size()) +
                                " odometry poses (or mismatched times)");
  if (format == ScanSetFormat::Auto) // 3DTK's frame has y up: 2D scans are KITTI's, z up
    format = set.point_times.empty() && !isPlanar(set.scanner) ? ScanSetFormat::Uos
                                                               : ScanSetFormat::Kitti;
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec || !fs::is_directory(dir))
    throw std::runtime_error("pcl_parallel::sim: cannot create directory " + dir +
                             (ec ? ": " + ec.message() : ""));
  const fs::path root(dir);
  std::vector<Eigen::Matrix4d> truth = set.truth;
  if (format == ScanSetFormat::Uos)
    writeUosScans(set, root, truth);
  else
    writeKittiScans(set, root, format == ScanSetFormat::Pcd);
  io::writeKittiPoses((root / "ground_truth.txt").string(), truth);
}

bool
isScanSetName(const std::string& name)
{
  using io::detail::isNumberedName;
  return isNumberedName(name, "scan", 3, {".3d", ".pose"}) ||
         isNumberedName(name, "", 6, {".bin", ".pcd"}) ||
         io::detail::isOneOf(name, {"odometry.txt", "times.txt", "ground_truth.txt"});
}

ScanSetFormat
scanSetFormatFromString(const std::string& name)
{
  if (name == "auto")
    return ScanSetFormat::Auto;
  if (name == "uos")
    return ScanSetFormat::Uos;
  if (name == "kitti")
    return ScanSetFormat::Kitti;
  if (name == "pcd")
    return ScanSetFormat::Pcd;
  throw std::invalid_argument("pcl_parallel::sim: unknown scan set format '" + name +
                              "' (auto, uos, kitti, pcd)");
}

ScanSetSummary
simulateToDirectory(const std::string& preset,
                    const PresetOptions& options,
                    const std::string& dir,
                    ScanSetFormat format)
{
  const SimulatedScanSet set = simulatePreset(preset, options);
  writeScanSet(set, dir, format);
  ScanSetSummary summary;
  summary.scans = set.scans.size();
  for (const auto& s : set.scans)
    summary.points += s->size();
  summary.moving = !set.point_times.empty();
  return summary;
}

} // namespace sim
} // namespace pcl_parallel
