/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * Writes the seed corpora of the fuzz harnesses: write_fuzz_seeds DIR creates DIR/<target>/
 * with small valid (and a few borderline) inputs of each format, generated here (PCD and
 * PLY by PCL's own writers), never copied from data sets.
 */
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

fs::path root;

void
seed(const std::string& target, const std::string& name, const std::string& bytes)
{
  fs::create_directories(root / target);
  std::ofstream(root / target / name, std::ios::binary) << bytes;
}

std::string
floats(std::initializer_list<float> values) // little-endian float32, as KITTI
{
  std::string bytes;
  for (float v : values) {
    std::uint32_t u;
    std::memcpy(&u, &v, sizeof u);
    for (int i = 0; i < 4; ++i)
      bytes.push_back(static_cast<char>((u >> (8 * i)) & 0xffu));
  }
  return bytes;
}

std::string
slurp(const fs::path& p)
{
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

} // namespace

int
main(int argc, char** argv)
{
  if (argc != 2) {
    std::fprintf(stderr, "usage: write_fuzz_seeds DIR\n");
    return 2;
  }
  root = argv[1];

  seed("uos_scan", "plain", "10.1 0 0\n10.0996 -0.0662149 0.0581712\n-1e3 2e-2 +3.5 17\n");
  seed("uos_scan", "header", "360 x 225\n1 2 3\n\n4 5 6 7 8\r\n3276.7 0 0\n");
  seed("uos_pose", "pose", "1.5 -2 3e2\n90 0 -45.5\n");
  seed("frames",
       "frames",
       "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 2\n"
       "0.99 0.01 0 0 -0.01 0.99 0 0 0 0 1 0 12.5 -3 337.79 1 1\n");
  seed("xyz", "xyz", "# x y z i\n1 2 3 0.5\n4\t5\t6\n7,8,9,255,0,0\n-1.5 , +2.5,3e1 l\n");
  seed("xyz", "nan", "nan nan nan 0\n1 inf 0\n1e39 0 0\n");
  seed("kitti_scan", "scan", floats({1.25f, -2.5f, 0.125f, 0.75f, 10, 0, -0.5f, 0.25f}));
  seed("kitti_scan",
       "nan",
       floats({std::numeric_limits<float>::quiet_NaN(), 1, 1, 0.5f, 0.01f, 0.02f, 0.03f, 1}));
  seed("kitti_poses",
       "poses",
       "1 0 0 1.5 0 1 0 -2 0 0 1 3\n\n0 -1 0 10 1 0 0 20 0 0 1 3.000000e+01\n");
  seed("stanford_conf",
       "conf",
       "camera -0.0172 -0.0936 -0.734  -0.0461723 0.970603 -0.235889 0.0124573\n"
       "bmesh a.ply 0 0 0 0 0 0 1\n"
       "bmesh b.ply -0.052 -0.00038 -0.0109 0.0054 -0.2946 -0.0038 0.9555\n");
  // Trajectories (pose_files.h) and `pcl_pslam evaluate` on two of them.
  const std::string tum =
      "# timestamp tx ty tz qx qy qz qw\n"
      "1305031102.175304 1.3405 0.6266 1.6575 0.6574 0.6126 -0.2949 -0.3248\n"
      "1305031102.211214 1.3303 0.6256 1.6464 0.6579 0.6161 -0.2932 -0.3189\n"
      "1305031102.243211 1.3160 0.6254 1.6302 0.6609 0.6199 -0.2893 -0.3086\n";
  const std::string kitti = "1 0 0 0 0 1 0 0 0 0 1 0\n"
                            "0.99995 -0.0099998 0 1.2 0.0099998 0.99995 0 0.1 0 0 1 0\n"
                            "0.9998 -0.019999 0 2.5 0.019999 0.9998 0 0.3 0 0 1 0.01\n"
                            "0.99955 -0.029996 0 3.7 0.029996 0.99955 0 0.6 0 0 1 -0.02\n";
  const std::string frame = "1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1 2\n";
  const std::string moved = "0.99 0.01 0 0 -0.01 0.99 0 0 0 0 1 0 12.5 -3 337.79 1 1\n";
  seed("kitti_times", "times", "0.000000e+00\n1.036594e-01\n\n2.072864e-01\r\n+3.1e-1\n");
  seed("tum", "tum", tum);
  seed("tum", "crlf", "0 0 0 0 0 0 0 1\r\n1.5 +1 -2 3e-1 0 0 0.7071068 0.7071068\r\n");
  seed("frames_history", "history", frame + moved + frame);
  seed("trajectory", "kitti", kitti);
  seed("trajectory", "tum", tum);
  seed("frames_dir",
       "numbered",
       "scan000.frames\n" + frame + std::string(1, '\0') + "scan001.frames\n" + frame + moved +
           std::string(1, '\0') + "scan1000.frames\n" + moved + std::string(1, '\0') +
           "other.frames\n" + frame + std::string(1, '\0') + "scan002.3d\n0 0 0\n");
  // The 2D logs (io/carmen.h) and Kuemmerle et al.'s relations (evaluation/relations.h).
  seed("carmen",
       "messages",
       "# CARMEN Logfile\nPARAM laser_front_laser_resolution 0.5 1 h 1\n"
       "PARAM robot_frontlaser_offset 0.0 nohost 0\n"
       "FLASER 3 1.07 81.83 2.5 1 2 0.5 1 2.04 0.5 976052857.5 nohost 0.1\r\n"
       "ODOM 0 0 -0.002458 0 0 0 976052857.337284 nohost 0.000000\n"
       "ROBOTLASER1 0 -1.0 2.0 0.5 3.0 0.01 0 2 1 2 1 7 0.5 0.25 0.1 0.5 0.5 0.2 0 0 0 0 0 "
       "12.5 h 3.5\nRLASER 1 2.0 0 0 0 0 0 0 1 h 1\n");
  seed("relations",
       "freiburg",
       "1185.029675 1185.237675 0.055262 -0.000206 0.000000 0.000000 0.000000 0.001014\n"
       "# comment\n10 20 1 2 3 0.1 0.2 0.3\r\n");
  seed("evaluate", "kitti_kitti", kitti + std::string(1, '\0') + kitti);
  seed("evaluate", "tum_tum", tum + std::string(1, '\0') + tum);
  seed("evaluate", "tum_kitti", tum + std::string(1, '\0') + kitti.substr(0, 3 * 26));
  // `run`'s command line: NUL-separated tokens after "pcl_pslam run" (or demo).
  const auto command = [](std::initializer_list<const char*> tokens) {
    std::string bytes;
    for (const char* t : tokens)
      bytes += std::string(t) + '\0';
    return bytes;
  };
  seed("options",
       "slam6d",
       command({"-s",
                "0",
                "-e",
                "65",
                "-r",
                "10",
                "-i",
                "100",
                "-d",
                "75",
                "-D",
                "250",
                "-I",
                "50",
                "--cldist",
                "750",
                "-f",
                "uos",
                "dat"}));
  seed("options",
       "deskew",
       command({"dir",
                "--deskew",
                "--sweep-period",
                "0.1",
                "--scale",
                "0.001",
                "-m",
                "120",
                "-M",
                "2",
                "--icp-final",
                "0.3",
                "-t",
                "4"}));
  seed("options",
       "ranges",
       command({"dir",
                "-r",
                "1e-9",
                "--epsICP",
                "1e-30",
                "--map-voxel",
                "0",
                "--segment-size",
                "3",
                "--segment-overlap",
                "1"}));
  seed("poses", "kitti", kitti);
  seed("poses", "mirrored", "-1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1e10 0 1 0 0 0 0 1 0\n");

  pcl::PointCloud<pcl::PointXYZ> cloud;
  for (int i = 0; i < 5; ++i)
    cloud.push_back(pcl::PointXYZ(0.5f * i, -1.25f + i, 2.0f));
  cloud.push_back(pcl::PointXYZ(std::numeric_limits<float>::quiet_NaN(), 0, 0));
  cloud.is_dense = false;
  const fs::path tmp = fs::temp_directory_path() / "pcl_parallel_fuzz_seed";
  const std::string pcd = tmp.string() + ".pcd", ply = tmp.string() + ".ply";
  pcl::io::savePCDFileASCII(pcd, cloud);
  seed("pcd", "ascii", slurp(pcd));
  pcl::io::savePCDFileBinary(pcd, cloud);
  seed("pcd", "binary", slurp(pcd));
  pcl::io::savePCDFileBinaryCompressed(pcd, cloud);
  seed("pcd", "binary_compressed", slurp(pcd));
  pcl::io::savePLYFileASCII(ply, cloud);
  seed("ply", "ascii", slurp(ply));
  pcl::io::savePLYFileBinary(ply, cloud);
  seed("ply", "binary", slurp(ply));
  // Per-point time fields (Ouster's uint32 "t", Velodyne's float "time").
  seed("pcd",
       "time_field",
       "VERSION .7\nFIELDS x y z t\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 3\n"
       "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\n1 0 0 0\n0 2 0 50000\n"
       "0 0 3 100000\n");
  seed("ply",
       "time_field",
       "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
       "property float z\nproperty float time\nend_header\n1 0 0 0\n0 2 0 0.05\n");
  fs::remove(pcd);
  fs::remove(ply);
  return 0;
}
