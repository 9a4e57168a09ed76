/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <Eigen/Core>

#include <limits>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace io {

/** The per-point time fields that loadPcdScan and loadPlyScan read, in order of
 *  preference (the first present wins): Ouster's "t" (ns from the sweep's start),
 *  Velodyne's "time" (s), "timestamp" (Hesai, Livox: absolute s), "time_stamp", Livox's
 *  "offset_time" (ns). */
inline constexpr const char* kPointTimeFields[] = {
    "t", "time", "timestamp", "time_stamp", "offset_time"};

/** Reads a plain-text point list (.xyz, .txt): one point per line, "x y z" separated by
 *  spaces, tabs or commas (one comma between two fields), so both the usual xyz exports
 *  and CSV without a header read. Further columns (intensity, RGB, labels) are ignored
 *  and need not be numbers. Blank lines and lines starting with '#' are skipped. A kept
 *  coordinate beyond float's range (finite as a double) is an error, not an inf.
 *  "nan" and "inf" are read as numbers and, like every non-finite point, dropped: exports
 *  of organised clouds write the empty cells that way. Points whose range
 *  sqrt(x²+y²+z²) lies outside [min_range, max_range] are dropped (as loadUosScan).
 *  Numbers are read independently of the C++ and C locales (a decimal point, never a
 *  comma). Throws std::runtime_error naming the file and line when it cannot be read, or
 *  when a line has fewer than three fields or a first-three field that is not a number.
 *  Unlike loadUosScan there is no header to skip: a line of text is an error, so a file
 *  in another format is not read as an empty scan; a file without any point line (empty,
 *  or comments only) is an error too, as for loadUosScan. */
pcl::PointCloud<pcl::PointXYZ>::Ptr
loadXyzScan(const std::string& path,
            double min_range = 0.0,
            double max_range = std::numeric_limits<double>::infinity());

/** Reads a KITTI Velodyne scan (.bin): little-endian float32 records (x, y, z,
 *  reflectance), 16 bytes a point, in metres in the sensor frame; the reflectance is
 *  dropped. The file is read in one block (a KITTI scan is ~120k points, ~2 MB). Range
 *  filter and non-finite points as loadXyzScan: a NaN or inf value is dropped. An empty
 *  file gives an empty cloud (a sensor that saw nothing is not an error). The format has
 *  no header, so only the values can be validated; throws std::runtime_error naming the
 *  file when it cannot be read, when its size is not a multiple of 16 bytes (a truncated
 *  download), when a finite value is beyond 1e5 in magnitude (the HDL-64E reaches
 *  120 m; reflectance is in [0, 1]), when more than half of the points have all three
 *  coordinates nonzero and below 1 mm (text read as float32), or when it starts like a PCD
 *  or PLY header. What cannot be detected: other float32 data of plausible magnitude (e.g.
 *  a 4-float cloud in another frame or unit, or 16-byte-aligned garbage that happens to
 *  look like coordinates). */
pcl::PointCloud<pcl::PointXYZ>::Ptr
loadKittiScan(const std::string& path,
              double min_range = 0.0,
              double max_range = std::numeric_limits<double>::infinity());

/** Reads a PCD scan (.pcd; PCD v0.7 as pcl::PCDWriter writes it, and v0.5's FIELDS-only
 *  headers): DATA ascii, binary or binary_compressed, the x, y, z fields as float32 or
 *  float64, other fields skipped. Parsed by us rather than by pcl::PCDReader, which trusts
 *  damaged headers (see src/io/pcd.cpp). Range filter and non-finite points as
 *  loadXyzScan; the VIEWPOINT is not applied (neither does PCL). Throws
 *  std::runtime_error naming the file, and the line for text, when the header is not a
 *  valid PCD header (a keyword twice or unknown, SIZE/TYPE/COUNT not one value a field,
 *  an invalid type, POINTS against WIDTH x HEIGHT), x, y or z is missing or not a single
 *  float, an ASCII line has another number of values than the fields take, or the body
 *  holds fewer points than the header (or, compressed, does not decompress to them).
 *  With `point_times`, it receives the time of each returned point from the file's
 *  per-point time field as stored (see kPointTimeFields for the names; the unit is the
 *  driver's), or is left empty when there is none; a kept point whose time is not a finite
 *  number is then an error naming the file and point. */
pcl::PointCloud<pcl::PointXYZ>::Ptr
loadPcdScan(const std::string& path,
            double min_range = 0.0,
            double max_range = std::numeric_limits<double>::infinity(),
            std::vector<double>* point_times = nullptr);

/** Reads a PLY scan (.ply; ascii, binary_little_endian or binary_big_endian): the vertex
 *  element's x, y, z (float or double), other properties and elements skipped by their
 *  declared layout. Parsed by us rather than by pcl::PLYReader, which asserts or loops on
 *  damaged headers (see src/io/ply.cpp). Range filter and non-finite points as
 *  loadXyzScan. Throws std::runtime_error naming the file, and the line for text, when
 *  the header is not a valid PLY header (no "ply" line, a format other than 1.0, an
 *  unknown keyword or type, element counts beyond the file size, no vertex element with
 *  x, y, z as single floats), or the data ends before the vertices do or does not match
 *  the declared properties. `point_times` as loadPcdScan's, from a vertex property. */
pcl::PointCloud<pcl::PointXYZ>::Ptr
loadPlyScan(const std::string& path,
            double min_range = 0.0,
            double max_range = std::numeric_limits<double>::infinity(),
            std::vector<double>* point_times = nullptr);

/** Writes x y z of every point as a binary PCD v0.7 (float32, host order), byte for byte
 *  what pcl::io::savePCDFileBinary writes for a PointXYZ cloud, atomically
 *  (writeAtomically); a failed write (a full disk) throws std::runtime_error naming
 *  `path` and leaves no file. PCL's writer fills an mmap (a full disk is a SIGBUS where
 *  fallocate is unsupported) and its exceptions do not name the file. */
void
writePcdScan(const std::string& path, const pcl::PointCloud<pcl::PointXYZ>& cloud);

/** Writes x y z of every point as a binary PLY 1.0 in host byte order, atomically, as
 *  writePcdScan; loadPlyScan and PCL read it back. PCL 1.13's PLY writer reports success
 *  for a file cut short by a full disk. */
void
writePlyScan(const std::string& path, const pcl::PointCloud<pcl::PointXYZ>& cloud);

/** Reads a KITTI odometry poses file (poses/NN.txt): one pose a line, 12 numbers, the
 *  first three rows of [R|t] in row-major order, p_world = R·p + t (the left camera's
 *  frame at the first scan is the world frame; the poses are of that camera, so a
 *  Velodyne scan needs the calib.txt "Tr" transform first). Returns the 4x4 matrices, one
 *  a non-blank line, in file order, so index i is scan i. Throws std::runtime_error naming the
 * file and line when it cannot be read, or when a line does not hold exactly 12 finite numbers
 * (a missing or extra value would silently shift the matrix). */
std::vector<Eigen::Matrix4d>
loadKittiPoses(const std::string& path);

/** Reads a scan in any supported format, chosen by the extension (case-insensitive):
 *  .3d (loadUosScan), .xyz and .txt (loadXyzScan), .bin (loadKittiScan), .pcd
 *  (loadPcdScan) and .ply (loadPlyScan). Every format gets the same treatment: non-finite
 *  points dropped, and points at the origin (drivers write (0, 0, 0) for a beam without a
 *  return, Ouster's organised clouds for often more than half the points), the range
 *  filter applied, an unorganised dense cloud returned. Throws std::invalid_argument for
 *  an unsupported extension (the message lists the supported ones), std::runtime_error
 *  naming the file when it does not exist, is not a regular file, or cannot be parsed
 *  (also for PCD/PLY files without x, y, z fields), when a PCD/PLY header claims more
 *  points than the file size can hold, and when memory runs out (no bare std::bad_alloc).
 *  `point_times`, if given, receives the per-point times of PCD and PLY scans that have a
 *  time field (loadPcdScan); it stays empty for the other formats. */
pcl::PointCloud<pcl::PointXYZ>::Ptr
loadScan(const std::string& path,
         double min_range = 0.0,
         double max_range = std::numeric_limits<double>::infinity(),
         std::vector<double>* point_times = nullptr);

/** True when loadScan supports the extension of \a path (case-insensitive); looks at the
 *  name only, not the file, so it serves to filter a directory listing. */
bool
isScanFile(const std::string& path);

/** The scan format (extension, lower case) for a 3DTK -f name or an extension, any case:
 *  uos and 3d -> 3d, velodyne, kitti and bin -> bin, pcl -> pcd, else the extension where
 *  loadScan reads it, else "". */
std::string
scanFormatFromName(const std::string& name);

} // namespace io
} // namespace pcl_parallel
