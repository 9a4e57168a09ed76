/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * k-d tree benchmark: build time and nearest-neighbour throughput of KdTreeIndex
 * against PCL's FLANN-backed pcl::search::KdTree, 1 vs N threads, padded vs unpadded
 * per-thread state (paper Sec. IV-B), and the bucket size.
 */
#include "bench_common.h"

#include <pcl_parallel/io/uos.h>
#include <pcl_parallel/kdtree.h>
#include <pcl_parallel/search/kdtree.h>

#include <pcl/common/transforms.h>
#include <pcl/search/kdtree.h>

#include <filesystem>
#include <random>

namespace pcl_parallel {
namespace bench {

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

/** Target: scans 000+001 of 3dtk_dat in the world frame (odometry), ranges 50-3000 cm,
 *  thinned evenly to 100,000 points. Queries: scan 002 in the world frame. Falls back
 *  to a synthetic cloud of the same size when the data is absent. */
bool
loadScenario(const std::string& data_dir, Cloud& target, Cloud& queries, std::string& what)
{
  const std::filesystem::path dir = std::filesystem::path(data_dir) / "3dtk_dat";
  if (!std::filesystem::exists(dir / "scan002.3d")) {
    std::mt19937 rng(1);
    std::uniform_real_distribution<float> u(-1000.0f, 1000.0f);
    for (int i = 0; i < 100000; ++i)
      target.push_back(pcl::PointXYZ(u(rng), u(rng), u(rng)));
    for (int i = 0; i < 70000; ++i)
      queries.push_back(pcl::PointXYZ(u(rng), u(rng), u(rng)));
    what = "synthetic uniform cloud (3dtk_dat not found)";
    return false;
  }
  auto world = [&](const std::string& scan) {
    const auto cloud = io::loadUosScan((dir / (scan + ".3d")).string(), 50.0, 3000.0);
    const Eigen::Matrix4d pose = io::loadUosPose((dir / (scan + ".pose")).string());
    Cloud out;
    pcl::transformPointCloud(*cloud, out, Eigen::Matrix4f(pose.cast<float>()));
    return out;
  };
  Cloud both = world("scan000");
  both += world("scan001");
  const double step = static_cast<double>(both.size()) / 100000.0;
  for (int i = 0; i < 100000 && step >= 1.0; ++i)
    target.push_back(both[static_cast<std::size_t>(i * step)]);
  queries = world("scan002");
  what = "3dtk_dat scans 000+001 (100,000 points, cm) queried with scan 002 (" +
         std::to_string(queries.size()) + " points)";
  return true;
}

} // namespace

int
runKdTree(const Options& opt)
{
  Cloud::Ptr target(new Cloud);
  Cloud queries;
  std::string what;
  loadScenario(opt.data_dir, *target, queries, what);
  const std::size_t nq = queries.size();
  const float* qdata = queries.front().data;
  const float inf = std::numeric_limits<float>::infinity();
  const unsigned max_threads = *std::max_element(opt.threads.begin(), opt.threads.end());
  const double spin_before = spinSpeedup(max_threads);
  std::printf("## k-d tree: %s\n\n", what.c_str());

  // --- build ---
  Table build({"build", "threads", "median ms", "vs PCL"});
  pcl::search::KdTree<pcl::PointXYZ> flann;
  const double t_flann = medianSeconds(opt.repeats, [&] { flann.setInputCloud(target); });
  build.addRow({"pcl::search::KdTree (FLANN)", "1", fmt("%.1f", 1e3 * t_flann), "1.00x"});
  KdTreeIndex tree;
  for (unsigned t : opt.threads) {
    const double s = medianSeconds(
        opt.repeats, [&] { tree.build(target->front().data, target->size(), 4, nullptr, t); });
    build.addRow({"pcl_parallel::KdTreeIndex",
                  std::to_string(t),
                  fmt("%.1f", 1e3 * s),
                  fmt("%.2fx", t_flann / s)});
  }
  build.print();

  // --- nearest-neighbour queries ---
  Table nn({"nearest neighbour (all queries)", "threads", "Mqueries/s", "vs PCL"});
  pcl::Indices idx(1);
  std::vector<float> d2(1);
  const double t_pcl = medianSeconds(opt.repeats, [&] {
    for (const auto& q : queries)
      flann.nearestKSearch(q, 1, idx, d2);
  });
  auto rate = [&](double s) { return fmt("%.2f", static_cast<double>(nq) / s / 1e6); };
  nn.addRow({"pcl::search::KdTree::nearestKSearch(k=1)", "1", rate(t_pcl), "1.00x"});

  pcl_parallel::search::KdTree<pcl::PointXYZ> ours_search;
  ours_search.setInputCloud(target);
  const double t_ours_search = medianSeconds(opt.repeats, [&] {
    for (const auto& q : queries)
      ours_search.nearestKSearch(q, 1, idx, d2);
  });
  nn.addRow({"pcl_parallel::search::KdTree::nearestKSearch(k=1)",
             "1",
             rate(t_ours_search),
             fmt("%.2fx", t_pcl / t_ours_search)});

  std::vector<std::uint32_t> pos(nq);
  std::vector<float> dist(nq);
  const double t_single = medianSeconds(opt.repeats, [&] {
    float dd;
    for (std::size_t i = 0; i < nq; ++i)
      pos[i] = tree.nearest(qdata + 4 * i, inf, dd);
  });
  nn.addRow({"KdTreeIndex::nearest (one query at a time)",
             "1",
             rate(t_single),
             fmt("%.2fx", t_pcl / t_single)});
  double t_batch1 = 0.0;
  for (unsigned t : opt.threads) {
    const double s = medianSeconds(
        opt.repeats, [&] { tree.nearestBatch(qdata, nq, 4, inf, pos.data(), dist.data(), t); });
    if (t == 1)
      t_batch1 = s;
    nn.addRow(
        {"KdTreeIndex::nearestBatch", std::to_string(t), rate(s), fmt("%.2fx", t_pcl / s)});
  }
  for (unsigned t : opt.threads) {
    const double s = medianSeconds(opt.repeats, [&] {
      tree.nearestBatch(qdata, nq, 4, 25.0f * 25.0f, pos.data(), dist.data(), t);
    });
    nn.addRow({"KdTreeIndex::nearestBatch, max distance 25 (as ICP)",
               std::to_string(t),
               rate(s),
               fmt("%.2fx", t_pcl / s)});
  }
  nn.print();
  if (t_batch1 > 0.0)
    std::printf("Batch speed-up over one thread: see the threads column; one-thread batch "
                "= %.2f Mqueries/s.\n\n",
                static_cast<double>(nq) / t_batch1 / 1e6);

  // --- padded vs unpadded per-thread state (Sec. IV-B) ---
  Table pad({"per-thread slot", "threads", "Mqueries/s", "padded / packed"});
  for (unsigned t : opt.threads) {
    const double padded = medianSeconds(opt.repeats, [&] {
      tree.nearestBatch(qdata, nq, 4, inf, pos.data(), dist.data(), t, SlotLayout::kPadded);
    });
    const double packed = medianSeconds(opt.repeats, [&] {
      tree.nearestBatch(qdata, nq, 4, inf, pos.data(), dist.data(), t, SlotLayout::kPacked);
    });
    pad.addRow({"padded (64 B, alignas)", std::to_string(t), rate(padded), ""});
    pad.addRow(
        {"packed (16 B)", std::to_string(t), rate(packed), fmt("%.3f", packed / padded)});
  }
  pad.print();

  // --- bucket size ---
  Table bucket({"bucket size", "nodes", "build ms (1 thread)", "Mqueries/s (1 thread)"});
  for (unsigned b : {1u, 2u, 4u, 6u, 8u, 12u, 16u, 32u}) {
    KdTreeIndex t;
    const double sb = medianSeconds(
        opt.repeats, [&] { t.build(target->front().data, target->size(), 4, nullptr, 1, b); });
    const double sq = medianSeconds(
        opt.repeats, [&] { t.nearestBatch(qdata, nq, 4, inf, pos.data(), dist.data(), 1); });
    bucket.addRow(
        {std::to_string(b), std::to_string(t.numNodes()), fmt("%.1f", 1e3 * sb), rate(sq)});
  }
  bucket.print();
  std::printf("Machine check: a compute-bound OpenMP loop ran %.2fx faster on %u threads than "
              "on 1 before these tables and %.2fx after them (%u on an idle machine).\n\n",
              spin_before,
              max_threads,
              spinSpeedup(max_threads),
              max_threads);
  return 0;
}

} // namespace bench
} // namespace pcl_parallel
