/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * "lum": pLUM (ParallelLUM) vs pcl::registration::LUM.
 *  1. Stanford bunny, one iteration (pairs of every link + linearisation + solve), poses
 *     = bun.conf perturbed by 2 deg / 3 mm, pairs within 5 mm; PCL as its pcl_lum tool
 *     drives it (CorrespondenceEstimation per link on the transformed clouds, then
 *     LUM::compute with one iteration).
 *  2. The whole pLUM relaxation of the bunny: the paper's (50 iterations, gate 10 mm ->
 *     2 mm) and with point-to-plane pairs and 5 pairing steps per link (to convergence).
 *  3. Solve-step scaling on synthetic graphs (chain + loop links) of 100-10,000 poses.
 */
#include "bench_common.h"
#include "synthetic_graph.h"

#include <pcl_parallel/io/stanford.h>
#include <pcl_parallel/pose_math.h>
#include <pcl_parallel/registration/lum.h>
#include <pcl_parallel/slam/loop_closure.h>

#include <pcl/common/transforms.h>
#include <pcl/registration/correspondence_estimation.h>
#include <pcl/registration/lum.h>

#include <Eigen/Geometry>

#include <cmath>
#include <filesystem>
#include <random>

namespace pcl_parallel {
namespace bench {

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Poses = std::vector<Eigen::Matrix4d>;
constexpr double kDeg = M_PI / 180.0;
using Vertex6 = ParallelLUM<pcl::PointXYZ>::Vertex;

using test::perturb;

void
maxError(const Poses& a, const Poses& b, double& rot, double& trans)
{
  rot = trans = 0.0;
  for (std::size_t v = 1; v < a.size(); ++v) {
    const auto [r, t] = poseError(a[v], b[v]);
    rot = std::max(rot, r);
    trans = std::max(trans, t);
  }
}

/** PCL as pcl_lum drives it: one iteration = pairs of every link on the transformed
 *  clouds (a FLANN tree per target) + LUM::compute(). */
double
pclOneIteration(const std::vector<Cloud::Ptr>& clouds,
                const Poses& poses,
                const std::vector<std::pair<Vertex6, Vertex6>>& links)
{
  return seconds([&]() {
    pcl::registration::LUM<pcl::PointXYZ> lum;
    for (std::size_t v = 0; v < clouds.size(); ++v)
      lum.addPointCloud(clouds[v], matrixToPose(poses[v]));
    std::vector<Cloud::Ptr> moved;
    for (std::size_t v = 0; v < clouds.size(); ++v)
      moved.push_back(lum.getTransformedCloud(v));
    for (const auto& [i, j] : links) {
      pcl::registration::CorrespondenceEstimation<pcl::PointXYZ, pcl::PointXYZ> ce;
      ce.setInputSource(moved[i]);
      ce.setInputTarget(moved[j]);
      pcl::CorrespondencesPtr corrs(new pcl::Correspondences);
      ce.determineCorrespondences(*corrs, 0.005);
      lum.setCorrespondences(i, j, corrs);
    }
    lum.setMaxIterations(1);
    lum.compute();
  });
}

void
setUpOurs(ParallelLUM<pcl::PointXYZ>& lum,
          const std::vector<Cloud::Ptr>& clouds,
          const Poses& poses,
          const std::vector<std::pair<Vertex6, Vertex6>>& links)
{
  for (std::size_t v = 0; v < clouds.size(); ++v)
    lum.addPointCloud(clouds[v], Eigen::Matrix4f(poses[v].cast<float>()));
  for (std::size_t v = 0; v < clouds.size(); ++v)
    lum.setPoseMatrix(v, poses[v]);
  for (const auto& [i, j] : links)
    lum.addLink(i, j);
}

/** The bunny's scans and bun.conf's poses; false (and a line saying so) when absent. */
bool
loadBunny(const Options& opt, const char* what, std::vector<Cloud::Ptr>& clouds, Poses& truth)
{
  const std::string conf = opt.data_dir + "/stanford_bunny/bun.conf";
  if (!std::filesystem::exists(conf)) {
    std::printf("%s: %s not found, bunny part skipped\n\n", what, conf.c_str());
    return false;
  }
  for (const auto& e : io::loadStanfordConf(conf)) {
    clouds.push_back(
        io::loadStanfordScan((std::filesystem::path(conf).parent_path() / e.file).string()));
    truth.push_back(e.pose);
  }
  return true;
}

int
runBunny(const Options& opt)
{
  std::vector<Cloud::Ptr> clouds;
  Poses truth;
  if (!loadBunny(opt, "lum", clouds, truth))
    return 0;
  std::size_t points = 0;
  for (const auto& c : clouds)
    points += c->size();
  std::mt19937 rng(2007);
  Poses start = truth;
  for (std::size_t v = 1; v < truth.size(); ++v)
    start[v] = perturb(truth[v], 2.0 * kDeg, 0.003, rng);

  // Link sets: >= 30% overlap at ground truth (the test's graph), and all 45 pairs (the
  // issue's PCL measurement).
  std::vector<std::pair<Vertex6, Vertex6>> overlap_links, all_links;
  {
    ParallelLUM<pcl::PointXYZ> probe;
    setUpOurs(probe, clouds, truth, {});
    overlap_links = probe.findOverlappingPairs(0.005, 0.30);
  }
  for (std::size_t i = 0; i < clouds.size(); ++i)
    for (std::size_t j = i + 1; j < clouds.size(); ++j)
      all_links.emplace_back(i, j);

  std::printf("### LUM: Stanford bunny, one iteration\n\n");
  std::printf("10 scans, %zu points, all points queried, pairs within 5 mm, poses = bun.conf "
              "perturbed by 2 deg / 3 mm. PCL: CorrespondenceEstimation per link on the "
              "transformed clouds + LUM::compute (1 iteration), one run. Ours: "
              "ParallelLUM::compute (1 iteration, k-d trees built once beforehand, timed "
              "separately), median of %d; repeats start from the same poses with the previous "
              "run's matches as warm-start hints, as in an iteration loop.\n\n",
              points,
              opt.repeats);
  Table t({"links",
           "PCL 1 thread [s]",
           "ours, pairs as PCL (one direction) [s]",
           "same, cold (no warm-start hints) [s]",
           "ours, default (symmetric pairs) [s]",
           "tree build (once) [s]",
           "ours, point-to-plane, 5 link steps [s]",
           "trees + normals (once) [s]",
           "speed-up (same pairs)"});
  for (const auto* links : {&overlap_links, &all_links}) {
    const double pcl_s = pclOneIteration(clouds, start, *links);
    for (unsigned threads : opt.threads) {
      double one_dir = 0, sym = 0, build = 0, cold = 0;
      for (int symmetric = 0; symmetric < 2; ++symmetric) {
        ParallelLUM<pcl::PointXYZ> lum;
        lum.setNumberOfThreads(threads);
        setUpOurs(lum, clouds, start, *links);
        lum.setSymmetricCorrespondences(symmetric == 1);
        lum.setCorrespondenceDistance(0.005);
        lum.setMaxIterations(1);
        build = seconds([&]() { lum.computeOverlap(0, 1, 0.0); }); // builds the trees
        if (symmetric == 0)
          cold = seconds([&]() { lum.compute(); }); // first iteration: no hints yet
        const double s = medianSeconds(opt.repeats, [&]() {
          for (std::size_t v = 1; v < start.size(); ++v)
            lum.setPoseMatrix(v, start[v]);
          lum.compute();
        });
        (symmetric ? sym : one_dir) = s;
      }
      // Point-to-plane with 5 pairing steps per link (the test's relaxation), symmetric.
      ParallelLUM<pcl::PointXYZ> plane;
      plane.setNumberOfThreads(threads);
      setUpOurs(plane, clouds, start, *links);
      plane.setCorrespondenceDistance(0.005);
      plane.setPointToPlane(true);
      plane.setLinkIterations(5);
      plane.setMaxIterations(1);
      const double plane_build = seconds([&]() { plane.computeOverlap(0, 1, 0.0); });
      const double plane_s = medianSeconds(opt.repeats, [&]() {
        for (std::size_t v = 1; v < start.size(); ++v)
          plane.setPoseMatrix(v, start[v]);
        plane.compute();
      });
      t.addRow({fmt("%zu, %u thread(s)", links->size(), threads),
                fmt("%.2f", pcl_s),
                fmt("%.3f", one_dir),
                fmt("%.3f", cold),
                fmt("%.3f", sym),
                fmt("%.3f", build),
                fmt("%.3f", plane_s),
                fmt("%.3f", plane_build),
                fmt("%.0fx", pcl_s / one_dir)});
    }
  }
  t.print();

  std::printf("### LUM: Stanford bunny, whole pLUM relaxation\n\n");
  std::printf("%zu links (>= 30%% overlap), every 4th point queried (as test_lum; ours with "
              "symmetric pairs). Paper mode and PCL: 50 iterations, gate max(2 mm, 10 mm * "
              "0.9^k); PCL driven the same way as its pcl_lum tool: every iteration "
              "CorrespondenceEstimation per link on the transformed clouds with the same gate, "
              "then LUM::compute with one iteration. Point-to-plane mode: 5 pairing steps per "
              "link and iteration, gate max(2 mm, 5 mm * 0.7^k), until the mean update is "
              "below 1e-6 (at most 50 iterations). Peak: the largest maximum rotation error "
              "after any iteration. One run each.\n\n",
              overlap_links.size());
  Table r({"implementation", "time [s]", "start max error", "final max error"});
  {
    pcl::registration::LUM<pcl::PointXYZ> lum;
    std::vector<Cloud::Ptr> sub;
    for (const auto& c : clouds) {
      sub.emplace_back(new Cloud);
      for (std::size_t k = 0; k < c->size(); k += 4)
        sub.back()->push_back((*c)[k]);
    }
    for (std::size_t v = 0; v < clouds.size(); ++v)
      lum.addPointCloud(sub[v], matrixToPose(start[v]));
    lum.setMaxIterations(1);
    double peak = 0.0;
    const double s = seconds([&]() {
      for (int k = 0; k < 50; ++k) {
        for (const auto& [i, j] : overlap_links) {
          pcl::registration::CorrespondenceEstimation<pcl::PointXYZ, pcl::PointXYZ> ce;
          ce.setInputSource(lum.getTransformedCloud(i));
          ce.setInputTarget(lum.getTransformedCloud(j));
          pcl::CorrespondencesPtr corrs(new pcl::Correspondences);
          ce.determineCorrespondences(*corrs, std::max(0.002, 0.01 * std::pow(0.9, k)));
          lum.setCorrespondences(i, j, corrs);
        }
        lum.compute();
        Poses now;
        for (std::size_t v = 0; v < clouds.size(); ++v)
          now.push_back(lum.getTransformation(v).matrix().cast<double>());
        double rot, trans;
        maxError(now, truth, rot, trans);
        peak = std::max(peak, rot);
      }
    });
    Poses got;
    for (std::size_t v = 0; v < clouds.size(); ++v)
      got.push_back(lum.getTransformation(v).matrix().cast<double>());
    double r0, t0, r1, t1;
    maxError(start, truth, r0, t0);
    maxError(got, truth, r1, t1);
    r.addRow({"PCL LUM, 1 thread, 50 iterations",
              fmt("%.2f", s),
              fmt("%.2f deg, %.2f mm", r0 / kDeg, t0 * 1e3),
              fmt("%.2f deg (peak %.2f deg), %.2f mm", r1 / kDeg, peak / kDeg, t1 * 1e3)});
  }
  // Ours: the paper's pLUM with the same gate schedule, 50 iterations; and point-to-plane
  // pairs with 5 pairing steps per link and a 5 mm -> 2 mm gate (x0.7), to convergence.
  for (int mode = 0; mode < 2; ++mode)
    for (unsigned threads : opt.threads) {
      ParallelLUM<pcl::PointXYZ> lum;
      lum.setNumberOfThreads(threads);
      setUpOurs(lum, clouds, start, overlap_links);
      lum.setQueryStep(4);
      lum.setMaxIterations(50);
      if (mode == 0)
        lum.setCorrespondenceDistanceSchedule(0.01, 0.002, 0.9);
      else {
        lum.setCorrespondenceDistanceSchedule(0.005, 0.002, 0.7);
        lum.setPointToPlane(true);
        lum.setLinkIterations(5);
        lum.setConvergenceThreshold(1e-6f);
      }
      double peak = 0.0;
      lum.setIterationCallback([&](int, double) {
        Poses now;
        for (std::size_t v = 0; v < clouds.size(); ++v)
          now.push_back(lum.getPoseMatrix(v));
        double rot, trans;
        maxError(now, truth, rot, trans);
        peak = std::max(peak, rot);
      });
      const double s = seconds([&]() { lum.compute(); }); // includes the callback's few us
      Poses got;
      for (std::size_t v = 0; v < clouds.size(); ++v)
        got.push_back(lum.getPoseMatrix(v));
      double r0, t0, r1, t1;
      maxError(start, truth, r0, t0);
      maxError(got, truth, r1, t1);
      r.addRow({fmt("ours, %s, %u thread(s), %d iterations",
                    mode == 0 ? "paper (point-to-point)" : "point-to-plane, 5 link steps",
                    threads,
                    lum.getNumIterationsDone()),
                fmt("%.2f", s),
                fmt("%.2f deg, %.2f mm", r0 / kDeg, t0 * 1e3),
                fmt("%.2f deg (peak %.2f deg), %.2f mm", r1 / kDeg, peak / kDeg, t1 * 1e3)});
    }
  r.print();
  return 0;
}

/** Chain links plus the pipeline's loop links (slam::loopCandidates, paper Sec. VI-C: closer
 *  than `distance`, at least `min_separation` apart, after a path of 2 x `distance` by
 *  translation alone), as (i, j) with i < j, sorted. */
std::vector<std::pair<std::uint32_t, std::uint32_t>>
chainAndLoopLinks(const Poses& poses, double distance, int min_separation)
{
  std::vector<std::pair<std::uint32_t, std::uint32_t>> links;
  for (std::size_t j = 1; j < poses.size(); ++j) {
    const auto to = static_cast<std::uint32_t>(j);
    links.emplace_back(to - 1, to);
    for (const std::uint32_t i : slam::loopCandidates(poses, j, distance, min_separation, 0.0))
      links.emplace_back(i, to);
  }
  std::sort(links.begin(), links.end());
  return links;
}

/** Two laps of a circle (radius 20 m, or `radius`) at heights 0 and 1 m: chain links
 *  plus loop links between the laps (chainAndLoopLinks: 1.5 m, >= 10 apart), 20 exact
 *  pairs per link with 1 mm noise. Start poses: truth with 1 deg / 0.1 m noise. At 20 m
 *  and 2000 poses the laps link every pose to ~20 others (a dense revisit); with the
 *  radius grown to keep poses 1 m apart, ~3 links a pose (a survey's sparse loops). */
struct SyntheticScaling {
  std::vector<Cloud::Ptr> clouds;
  Poses truth, start;
  std::vector<std::tuple<std::uint32_t, std::uint32_t, pcl::CorrespondencesPtr>> links;
};

SyntheticScaling
scalingGraph(int n, double radius = 20.0)
{
  SyntheticScaling g;
  std::mt19937 rng(static_cast<std::uint32_t>(n));
  for (int i = 0; i < n; ++i) {
    const double a = 4.0 * M_PI * i / n;
    Eigen::Matrix4d p = Eigen::Matrix4d::Identity();
    p.topLeftCorner<3, 3>() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    p.topRightCorner<3, 1>() = Eigen::Vector3d(
        radius * std::sin(a), radius * (1.0 - std::cos(a)), i < n / 2 ? 0.0 : 1.0);
    g.truth.push_back(p);
  }
  g.start = g.truth;
  for (int i = 1; i < n; ++i)
    g.start[i] = perturb(g.truth[i], 1.0 * kDeg, 0.1, rng);
  test::SyntheticGraph sg =
      test::makeGraph(g.truth, chainAndLoopLinks(g.truth, 1.5, 10), 20, 2.0, 0.001, rng);
  g.clouds = std::move(sg.clouds);
  g.links = std::move(sg.links);
  return g;
}

int
runScaling(const Options& opt)
{
  std::printf("### LUM: solve-step scaling (synthetic graphs)\n\n");
  std::printf("Two laps of a circle, chain + loop links (slam::loopCandidates, 1.5 m, "
              "10 scans apart), 20 fixed pairs per link, one iteration of compute() (fixed "
              "correspondences: linearisation + assembly + solve). PCL: LUM::compute, dense "
              "6(n-1) x 6(n-1) float system, column-pivoting QR; one run, skipped where "
              "it would take more than a minute (O(n^3) extrapolation from the smaller "
              "size). Ours: median of %d; 'solve' = assembly + SimplicialLDLT alone.\n\n",
              opt.repeats);
  Table t({"poses",
           "radius [m]",
           "links",
           "PCL LUM 1 iteration [s]",
           "ours 1 iteration [s]",
           "ours solve only [s]",
           "ours final max error",
           "speed-up"});
  double pcl_prev = 0.0;
  int n_prev = 0;
  // Dense revisits on a 20 m circle, then survey-like graphs (poses 1 m apart, ~3 links
  // a pose) up to the 10,000 scans of issue 12's model.
  const std::pair<int, double> sizes[] = {{100, 20.0},
                                          {500, 20.0},
                                          {2000, 20.0},
                                          {2000, 2000 / (4 * M_PI)},
                                          {10000, 10000 / (4 * M_PI)}};
  for (const auto& [n, radius] : sizes) {
    const SyntheticScaling g = scalingGraph(n, radius);
    // PCL, unless the O(n^3) extrapolation says more than a minute.
    double pcl_s = -1.0;
    const double predicted =
        n_prev > 0 ? pcl_prev * std::pow(static_cast<double>(n) / n_prev, 3.0) : 0.0;
    if (predicted < 60.0) {
      pcl_s = seconds([&]() {
        pcl::registration::LUM<pcl::PointXYZ> lum;
        for (int v = 0; v < n; ++v)
          lum.addPointCloud(g.clouds[v], matrixToPose(g.start[v]));
        for (const auto& [i, j, corrs] : g.links)
          lum.setCorrespondences(i, j, corrs);
        lum.setMaxIterations(1);
        lum.compute();
      });
      pcl_prev = pcl_s;
      n_prev = n;
    }
    ParallelLUM<pcl::PointXYZ> lum;
    lum.setNumberOfThreads(opt.threads.back());
    for (int v = 0; v < n; ++v)
      lum.addPointCloud(g.clouds[v], Eigen::Matrix4f(g.start[v].cast<float>()));
    for (int v = 0; v < n; ++v)
      lum.setPoseMatrix(v, g.start[v]);
    for (const auto& [i, j, corrs] : g.links)
      lum.setCorrespondences(i, j, corrs);
    lum.setMaxIterations(1);
    const double ours = medianSeconds(opt.repeats, [&]() {
      for (int v = 0; v < n; ++v)
        lum.setPoseMatrix(v, g.start[v]);
      lum.compute();
    });
    // The solve alone, on the blocks of the start poses.
    std::vector<lum::LinkBlock, Eigen::aligned_allocator<lum::LinkBlock>> blocks;
    for (const auto& [i, j, corrs] : g.links) {
      lum::LinkAccumulator acc;
      for (const auto& c : *corrs)
        acc.add((g.start[i] * (*g.clouds[i])[c.index_query].getVector4fMap().cast<double>())
                    .head<3>(),
                (g.start[j] * (*g.clouds[j])[c.index_match].getVector4fMap().cast<double>())
                    .head<3>());
      lum::LinkBlock b;
      b.source = i;
      b.target = j;
      b.valid = acc.finish(3, 1e-12, b.info, b.grad);
      blocks.push_back(b);
    }
    lum::PoseGraphSolver solver;
    std::vector<lum::Vector6d, Eigen::aligned_allocator<lum::Vector6d>> delta;
    const double solve = medianSeconds(opt.repeats, [&]() { solver.solve(n, blocks, delta); });
    // Converge ours to report the accuracy reached.
    lum.setMaxIterations(20);
    lum.setConvergenceThreshold(1e-9f);
    for (int v = 0; v < n; ++v)
      lum.setPoseMatrix(v, g.start[v]);
    lum.compute();
    Poses got;
    for (int v = 0; v < n; ++v)
      got.push_back(lum.getPoseMatrix(v));
    double r, tr;
    maxError(got, g.truth, r, tr);
    t.addRow({fmt("%d", n),
              fmt("%.0f", radius),
              fmt("%zu", g.links.size()),
              pcl_s >= 0 ? fmt("%.3f", pcl_s) : fmt("skipped (~%.0f s predicted)", predicted),
              fmt("%.4f", ours),
              fmt("%.4f", solve),
              fmt("%.3f deg, %.1f mm", r / kDeg, tr * 1e3),
              pcl_s >= 0 ? fmt("%.0fx", pcl_s / ours) : std::string("-")});
  }
  t.print();
  return 0;
}

/** test_lum's bunny convergence study over its start seeds: links at the start poses
 *  (>= 30 % overlap within 1 cm), every 4th point queried; the paper's pLUM (50 iterations,
 *  gate 10 mm -> 2 mm, x0.9) and point-to-plane with 5 link steps (gate 5 mm -> 2 mm, x0.7,
 *  until the mean update is below 1e-6). The test runs one seed of each. */
int
runBunnySeeds(const Options& opt)
{
  std::vector<Cloud::Ptr> clouds;
  Poses truth;
  if (!loadBunny(opt, "lum-seeds", clouds, truth))
    return 0;
  std::printf("### LUM: Stanford bunny, convergence from several start draws\n\n"
              "bun.conf perturbed by 2 deg / 3 mm per seed (test_lum's QuietPcl.Bunny*"
              "ConvergesToGroundTruth). Max: the largest error over the poses; peak: the "
              "largest maximum rotation error after any iteration.\n\n");
  Table t({"mode",
           "seed",
           "links",
           "iterations",
           "start max",
           "final max",
           "final mean rot",
           "peak rot"});
  for (const std::uint32_t seed : {2007u, 11u, 23u}) {
    std::mt19937 rng(seed);
    Poses start = truth;
    for (std::size_t v = 1; v < truth.size(); ++v)
      start[v] = perturb(truth[v], 2.0 * kDeg, 0.003, rng);
    for (int mode = 0; mode < 2; ++mode) {
      ParallelLUM<pcl::PointXYZ> lum;
      setUpOurs(lum, clouds, start, {});
      for (const auto& [i, j] : lum.findOverlappingPairs(0.01, 0.30))
        lum.addLink(i, j);
      lum.setQueryStep(4);
      lum.setMaxIterations(mode == 0 ? 50 : 20);
      if (mode == 0)
        lum.setCorrespondenceDistanceSchedule(0.01, 0.002, 0.9);
      else {
        lum.setPointToPlane(true);
        lum.setLinkIterations(5);
        lum.setCorrespondenceDistanceSchedule(0.005, 0.002, 0.7);
        lum.setConvergenceThreshold(1e-6f);
      }
      const auto poses = [&]() {
        Poses now;
        for (std::size_t v = 0; v < clouds.size(); ++v)
          now.push_back(lum.getPoseMatrix(v));
        return now;
      };
      double peak = 0.0, rot, trans;
      lum.setIterationCallback([&](int, double) {
        maxError(poses(), truth, rot, trans);
        peak = std::max(peak, rot);
      });
      lum.compute();
      const Poses got = poses();
      double r0, t0, r1, t1, mean_rot = 0.0;
      maxError(start, truth, r0, t0);
      maxError(got, truth, r1, t1);
      for (std::size_t v = 1; v < got.size(); ++v)
        mean_rot += poseError(got[v], truth[v]).angle / static_cast<double>(got.size() - 1);
      t.addRow({mode == 0 ? "paper (point-to-point)" : "point-to-plane, 5 link steps",
                fmt("%u", seed),
                fmt("%zu", boost::num_edges(*lum.getLoopGraph())),
                fmt("%d", lum.getNumIterationsDone()),
                fmt("%.3f deg, %.3f mm", r0 / kDeg, t0 * 1e3),
                fmt("%.3f deg, %.3f mm", r1 / kDeg, t1 * 1e3),
                fmt("%.3f deg", mean_rot / kDeg),
                fmt("%.3f deg", peak / kDeg)});
    }
  }
  t.print();
  return 0;
}

} // namespace

int
runLum(const Options& opt)
{
  int rc = runBunny(opt);
  rc |= runScaling(opt);
  return rc;
}

int
runLumBunny(const Options& opt)
{
  return runBunny(opt);
}

int
runLumScaling(const Options& opt)
{
  return runScaling(opt);
}

int
runLumSeeds(const Options& opt)
{
  return runBunnySeeds(opt);
}

} // namespace bench
} // namespace pcl_parallel
