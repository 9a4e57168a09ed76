/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * ICP benchmark: pcl::IterativeClosestPoint vs ParallelIterativeClosestPoint (1..N
 * threads), and Open3D's point-to-point ICP when built with it, on the 3DTK pair, the
 * Stanford bunny pair and a synthetic 300k-point pair. Same parameters for every column.
 */
// GCC 12 false positives inside PCL's TransformationEstimationSVD (see
// src/registration/icp.cpp).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Warray-bounds"
#pragma GCC diagnostic ignored "-Wuse-after-free"
#endif
#include "bench_common.h"
#include "synthetic_graph.h"

#include <pcl_parallel/io/stanford.h>
#include <pcl_parallel/io/uos.h>
#include <pcl_parallel/normal_estimation.h>
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/registration/icp.h>

#include <pcl/common/io.h>
#include <pcl/common/transforms.h>
#include <pcl/registration/icp.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>

#ifdef PCL_PARALLEL_HAVE_OPEN3D
#include <omp.h>

#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/Registration.h>
#include <open3d/utility/Logging.h>
#endif

namespace pcl_parallel {
namespace bench {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

struct IcpCase {
  std::string name;
  Cloud::Ptr source, target;
  Eigen::Matrix4f guess;
  double max_distance;
  int max_iterations;
  double transformation_epsilon;
};

using test::Peek;

/** " (vs PCL: D deg, T)": how far our result lies from PCL's, in rotation and translation. */
std::string
versus(const Eigen::Matrix4f& pcl_result, const Eigen::Matrix4f& ours)
{
  const Eigen::Matrix4f d = pcl_result.inverse() * ours;
  const double deg = rotationAngle(d.topLeftCorner<3, 3>().cast<double>()) * 180.0 / M_PI;
  return fmt(
      " (vs PCL: %.4f deg, %.2g)", deg, static_cast<double>(d.topRightCorner<3, 1>().norm()));
}

/** The "speed-up vs PCL" cell: "-" where PCL was not timed (--no-reference). */
std::string
speedup(double t_pcl, double t)
{
  return t_pcl > 0.0 ? fmt("%.2f", t_pcl / t) : "-";
}

template <typename Reg>
void
configure(Reg& reg, const IcpCase& c)
{
  reg.setMaxCorrespondenceDistance(c.max_distance);
  reg.setMaximumIterations(c.max_iterations);
  reg.setTransformationEpsilon(c.transformation_epsilon);
  reg.setInputSource(c.source);
  reg.setInputTarget(c.target);
}

std::vector<IcpCase>
loadCases(const Options& opt)
{
  std::vector<IcpCase> cases;
  const std::string dtk = opt.data_dir + "/3dtk_dat";
  if (std::filesystem::exists(dtk + "/scan001.3d")) {
    IcpCase c;
    c.name = "3dtk scan001->scan000";
    c.target = io::loadUosScan(dtk + "/scan000.3d", 50, 3000);
    c.source = io::loadUosScan(dtk + "/scan001.3d", 50, 3000);
    c.guess = (io::loadUosPose(dtk + "/scan000.pose").inverse() *
               io::loadUosPose(dtk + "/scan001.pose"))
                  .cast<float>();
    c.max_distance = 25.0;
    c.max_iterations = 50;
    c.transformation_epsilon = 0.0; // PCL's default
    cases.push_back(c);
  }
  else
    std::printf("(3dtk data not found under %s: skipped)\n", opt.data_dir.c_str());

  const std::string bun = opt.data_dir + "/stanford_bunny";
  if (std::filesystem::exists(bun + "/bun045.ply") &&
      std::filesystem::exists(bun + "/bun.conf")) {
    const Eigen::Matrix4f gt =
        io::stanfordPose(io::loadStanfordConf(bun + "/bun.conf"), "bun045.ply").cast<float>();
    IcpCase c;
    c.name = "bunny bun045->bun000";
    c.target = io::loadStanfordScan(bun + "/bun000.ply");
    c.source = io::loadStanfordScan(bun + "/bun045.ply");
    Eigen::Matrix4f perturb = Eigen::Matrix4f::Identity();
    perturb.topLeftCorner<3, 3>() = Eigen::AngleAxisf(3.0f * static_cast<float>(M_PI) / 180.0f,
                                                      Eigen::Vector3f(1, 1, 0).normalized())
                                        .toRotationMatrix();
    perturb.topRightCorner<3, 1>() << 0.005f, 0.0f, 0.0f;
    c.guess = perturb * gt; // ground truth perturbed by 3 deg / 5 mm
    c.max_distance = 0.02;
    c.max_iterations = 50;
    c.transformation_epsilon = 1e-10;
    cases.push_back(c);
  }
  else
    std::printf("(bunny data not found under %s: skipped)\n", opt.data_dir.c_str());

  {
    // Synthetic: 300k points on the faces of a 4 x 3 x 2.5 m "room" with a few boxes,
    // plus 1 cm noise; the source is the same geometry resampled and moved.
    auto sample = [](std::uint32_t seed) {
      std::mt19937 rng(seed);
      std::uniform_real_distribution<float> u(0.0f, 1.0f);
      std::normal_distribution<float> g(0.0f, 0.01f);
      Cloud::Ptr cloud(new Cloud);
      const float ext[3] = {4.0f, 3.0f, 2.5f};
      for (int i = 0; i < 300000; ++i) {
        const int face = i % 8;
        float p[3] = {u(rng) * ext[0], u(rng) * ext[1], u(rng) * ext[2]};
        if (face < 6)
          p[face / 2] = (face % 2) ? ext[face / 2] : 0.0f; // a wall
        else {                                             // a box in the room
          const float o = face == 6 ? 1.0f : 2.5f;
          p[0] = o + 0.5f * u(rng);
          p[1] = o * 0.6f + 0.5f * u(rng);
          p[2] = (i / 8) % 2 ? 0.8f : 0.5f * u(rng) + 0.3f;
        }
        cloud->push_back(pcl::PointXYZ(p[0] + g(rng), p[1] + g(rng), p[2] + g(rng)));
      }
      return cloud;
    };
    IcpCase c;
    c.name = "synthetic 300k";
    c.target = sample(1);
    Eigen::Affine3f motion(
        Eigen::AngleAxisf(0.05f, Eigen::Vector3f(0.2f, 0.3f, 1.0f).normalized()));
    motion.translation() << 0.08f, -0.05f, 0.03f;
    c.source.reset(new Cloud);
    pcl::transformPointCloud(*sample(2), *c.source, motion);
    c.guess = Eigen::Matrix4f::Identity();
    c.max_distance = 0.3;
    c.max_iterations = 50;
    c.transformation_epsilon = 1e-10;
    cases.push_back(c);
  }
  return cases;
}

/** Point-to-plane: PCL's IterativeClosestPointWithNormals (point-to-plane LLS) and pICP's
 *  point-to-plane on the same PointNormal clouds (target normals: ours, k = 10, stored in
 *  the fields, so both use the same ones), and pICP estimating the normals itself (the
 *  estimation is inside the timed align()). */
void
runIcpPointToPlane(const Options& opt, const std::vector<IcpCase>& cases)
{
  using NCloud = pcl::PointCloud<pcl::PointNormal>;
  std::printf("### Point-to-plane (median of %d repeats after one warm-up)\n\n", opt.repeats);
  Table table({"pair",
               "implementation",
               "threads",
               "time [s]",
               "iterations",
               "ms / iteration",
               "best [s]",
               "speed-up vs PCL",
               "speed-up vs 1 thread"});
  for (const IcpCase& c : cases) {
    NCloud::Ptr src(new NCloud), tgt(new NCloud);
    pcl::copyPointCloud(*c.source, *src);
    pcl::copyPointCloud(*c.target, *tgt);
    {
      search::KdTree<pcl::PointXYZ> tree;
      tree.setInputCloud(c.target);
      std::vector<float> nrm;
      estimateNormals(tree.index(), 10, 0, nrm);
      for (std::uint32_t pos = 0; pos < tree.index().size(); ++pos) {
        auto& q = (*tgt)[tree.index().id(pos)];
        q.normal_x = nrm[3 * pos];
        q.normal_y = nrm[3 * pos + 1];
        q.normal_z = nrm[3 * pos + 2];
      }
    }
    auto setUp = [&](auto& reg) {
      reg.setMaxCorrespondenceDistance(c.max_distance);
      reg.setMaximumIterations(c.max_iterations);
      reg.setTransformationEpsilon(c.transformation_epsilon);
      reg.setInputSource(src);
      reg.setInputTarget(tgt);
    };
    NCloud out;
    Timing tm_pcl{0.0, 0.0};
    Eigen::Matrix4f pcl_result = Eigen::Matrix4f::Identity();
    if (opt.reference) {
      pcl::IterativeClosestPointWithNormals<pcl::PointNormal, pcl::PointNormal> ref;
      setUp(ref);
      tm_pcl = timeRuns(opt.repeats, [&] { ref.align(out, c.guess); });
      const int it_pcl = Peek<decltype(ref)>::iterations(ref);
      table.addRow({c.name,
                    "pcl::IterativeClosestPointWithNormals",
                    "1",
                    fmt("%.3f", tm_pcl.median),
                    fmt("%d", it_pcl),
                    fmt("%.1f", 1e3 * tm_pcl.median / std::max(1, it_pcl)),
                    fmt("%.3f", tm_pcl.best),
                    "1.00",
                    "-"});
      pcl_result = ref.getFinalTransformation();
    }
    for (const bool estimate : {false, true}) {
      double t_one = 0.0;
      for (const unsigned threads : opt.threads) {
        registration::ParallelIterativeClosestPoint<pcl::PointNormal, pcl::PointNormal> icp;
        icp.setNumberOfThreads(threads);
        icp.setUsePointToPlane(true);
        icp.setUseTargetNormalFields(!estimate);
        setUp(icp);
        // Estimating: a new target each run, so the normals are computed every time.
        const Timing tm = timeRuns(opt.repeats, [&] {
          if (estimate)
            icp.setInputTarget(tgt);
          icp.align(out, c.guess);
        });
        const int it = Peek<decltype(icp)>::iterations(icp);
        if (t_one == 0.0)
          t_one = tm.median;
        table.addRow(
            {c.name,
             fmt("pICP point-to-plane, %s normals%s",
                 estimate ? "estimated" : "field",
                 opt.reference ? versus(pcl_result, icp.getFinalTransformation()).c_str() : ""),
             fmt("%u", resolveNumberOfThreads(threads)),
             fmt("%.3f", tm.median),
             fmt("%d", it),
             fmt("%.1f", 1e3 * tm.median / std::max(1, it)),
             fmt("%.3f", tm.best),
             speedup(tm_pcl.median, tm.median),
             fmt("%.2f", t_one / tm.median)});
      }
    }
  }
  table.print();
}

} // namespace

int
runIcp(const Options& opt)
{
  const unsigned max_threads = *std::max_element(opt.threads.begin(), opt.threads.end());
  const double spin_before = spinSpeedup(max_threads);
  std::printf("## ICP (median of %d repeats after one warm-up; %u hardware threads)\n\n",
              opt.repeats,
              hardwareThreads());
  const std::vector<IcpCase> cases = loadCases(opt);
  Table table({"pair",
               "points src/tgt",
               "implementation",
               "threads",
               "time [s]",
               "iterations",
               "ms / iteration",
               "best [s]",
               "speed-up vs PCL",
               "speed-up vs 1 thread"});
  for (const IcpCase& c : cases) {
    const std::string pts = fmt("%zu / %zu", c.source->size(), c.target->size());
    Cloud out;

    double t_pcl = 0.0;
    Eigen::Matrix4f pcl_result = Eigen::Matrix4f::Identity();
    if (opt.reference) {
      pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> ref;
      configure(ref, c);
      const Timing tm_pcl = timeRuns(opt.repeats, [&] { ref.align(out, c.guess); });
      t_pcl = tm_pcl.median;
      const int it_pcl = Peek<decltype(ref)>::iterations(ref);
      pcl_result = ref.getFinalTransformation();
      table.addRow({c.name,
                    pts,
                    "pcl::IterativeClosestPoint",
                    "1",
                    fmt("%.3f", t_pcl),
                    fmt("%d", it_pcl),
                    fmt("%.1f", 1e3 * t_pcl / std::max(1, it_pcl)),
                    fmt("%.3f", tm_pcl.best),
                    "1.00",
                    "-"});
    }

    double t_one = 0.0;
    for (const unsigned threads : opt.threads) {
      registration::ParallelIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
      icp.setNumberOfThreads(threads);
      configure(icp, c);
      const Timing tm = timeRuns(opt.repeats, [&] { icp.align(out, c.guess); });
      const double t = tm.median;
      const int it = Peek<decltype(icp)>::iterations(icp);
      if (threads == 1 || t_one == 0.0)
        t_one = t;
      table.addRow(
          {c.name,
           pts,
           fmt("pcl_parallel pICP%s",
               opt.reference ? versus(pcl_result, icp.getFinalTransformation()).c_str() : ""),
           fmt("%u", resolveNumberOfThreads(threads)),
           fmt("%.3f", t),
           fmt("%d", it),
           fmt("%.1f", 1e3 * t / std::max(1, it)),
           fmt("%.3f", tm.best),
           speedup(t_pcl, t),
           fmt("%.2f", t_one / t)});
    }

#ifdef PCL_PARALLEL_HAVE_OPEN3D
    if (opt.reference) {
      namespace o3r = open3d::pipelines::registration;
      open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
      auto toO3d = [](const Cloud& cloud) {
        open3d::geometry::PointCloud pc;
        pc.points_.reserve(cloud.size());
        for (const auto& p : cloud)
          pc.points_.emplace_back(p.x, p.y, p.z);
        return pc;
      };
      const auto src = toO3d(*c.source), tgt = toO3d(*c.target);
      double t_o3d_one = 0.0;
      for (const unsigned threads : opt.threads) {
        omp_set_num_threads(static_cast<int>(resolveNumberOfThreads(threads)));
        o3r::RegistrationResult res;
        // Open3D's criteria: relative fitness / RMSE 1e-6 (its defaults), same max its.
        const Timing tm = timeRuns(opt.repeats, [&] {
          res = o3r::RegistrationICP(src,
                                     tgt,
                                     c.max_distance,
                                     c.guess.cast<double>(),
                                     o3r::TransformationEstimationPointToPoint(false),
                                     o3r::ICPConvergenceCriteria(1e-6, 1e-6, c.max_iterations));
        });
        const double t = tm.median;
        if (t_o3d_one == 0.0)
          t_o3d_one = t;
        table.addRow({c.name,
                      pts,
                      "open3d RegistrationICP (point-to-point)",
                      fmt("%u", resolveNumberOfThreads(threads)),
                      fmt("%.3f", t),
                      "-",
                      "-",
                      fmt("%.3f", tm.best),
                      fmt("%.2f", t_pcl / t),
                      fmt("%.2f", t_o3d_one / t)});
      }
      omp_set_num_threads(static_cast<int>(hardwareThreads()));
    }
#endif
  }
  table.print();
  std::printf("Machine check: a compute-bound OpenMP loop ran %.2fx faster on %u threads than "
              "on 1 before this table and %.2fx after it (%u on an idle machine).\n\n",
              spin_before,
              max_threads,
              spinSpeedup(max_threads),
              max_threads);
#ifndef PCL_PARALLEL_HAVE_OPEN3D
  std::printf("(built without Open3D: no Open3D column)\n\n");
#endif
  runIcpPointToPlane(opt, cases);
  return 0;
}

} // namespace bench
} // namespace pcl_parallel
