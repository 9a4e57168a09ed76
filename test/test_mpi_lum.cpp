/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pLUM over MPI ranks (mpi::DistributedLUM), run by ctest under mpirun -np 1, 2 and 3:
 * poses bit-identical to one ParallelLUM for any rank and thread count, each rank loading
 * only its links' scans, and bad input ending every rank with rank 0's message.
 * `test_mpi_lum --fail-load` lets such an error end the job (ctest checks the message).
 */
#include "mpi_test.h"
#include "synthetic_graph.h"
#include "test_data.h"

#include <pcl_parallel/io/stanford.h>
#include <pcl_parallel/mpi/distributed_lum.h>

#include <pcl/console/print.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <gtest/gtest.h>
#include <map>
#include <set>
#include <stdexcept>

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using Poses = std::vector<Eigen::Matrix4d>;
using Links = std::vector<std::pair<std::size_t, std::size_t>>;
using pcl_parallel::ParallelLUM;
using DistributedLUM = pcl_parallel::mpi::DistributedLUM<pcl::PointXYZ>;
constexpr double kDeg = M_PI / 180.0;

using pcl_parallel::test::worldRank;
using pcl_parallel::test::worldSize;

/** A graph as every rank gets it: start poses, links, and the scans (on the ranks that
 *  load them through `load`). */
struct Problem {
  Poses start;
  Links links;
  std::function<Cloud::Ptr(std::size_t)> load;
};

/** The relaxation's options, the two modes of test_lum's thread test: the paper's pLUM,
 *  and point-to-plane with link iterations and a shrinking gate. */
void
configure(ParallelLUM<pcl::PointXYZ>& lum, bool options, double gate)
{
  lum.setQueryStep(4);
  lum.setMaxIterations(3);
  if (options) {
    lum.setPointToPlane(true);
    lum.setLinkIterations(3);
    lum.setCorrespondenceDistanceSchedule(gate, 0.5 * gate, 0.7);
  }
  else
    lum.setCorrespondenceDistance(gate);
}

/** Rank 0 picks the links at the start poses (never at ground truth) and broadcasts them. */
Links
linksAtStart(const std::vector<Cloud::Ptr>& clouds,
             const Poses& start,
             double distance,
             double overlap)
{
  std::vector<std::uint64_t> flat;
  if (worldRank() == 0) {
    ParallelLUM<pcl::PointXYZ> lum;
    for (std::size_t v = 0; v < clouds.size(); ++v)
      lum.addPointCloud(clouds[v], Eigen::Matrix4f::Identity());
    for (std::size_t v = 0; v < clouds.size(); ++v)
      lum.setPoseMatrix(v, start[v]);
    for (const auto& [i, j] : lum.findOverlappingPairs(distance, overlap)) {
      flat.push_back(i);
      flat.push_back(j);
    }
  }
  int count = static_cast<int>(flat.size());
  MPI_Bcast(&count, 1, MPI_INT, 0, MPI_COMM_WORLD);
  flat.resize(static_cast<std::size_t>(count));
  MPI_Bcast(flat.data(), count, MPI_UINT64_T, 0, MPI_COMM_WORLD);
  Links links;
  for (std::size_t k = 0; k < flat.size(); k += 2)
    links.emplace_back(flat[k], flat[k + 1]);
  return links;
}

/** Rank 0's in-process ParallelLUM (threads given), broadcast to every rank. */
Poses
reference(const Problem& p, bool options, double gate, unsigned threads)
{
  std::vector<double> flat(16 * p.start.size());
  if (worldRank() == 0) {
    ParallelLUM<pcl::PointXYZ> lum;
    lum.setNumberOfThreads(threads);
    configure(lum, options, gate);
    for (std::size_t v = 0; v < p.start.size(); ++v)
      lum.addPointCloud(p.load(v), Eigen::Matrix4f::Identity());
    for (std::size_t v = 0; v < p.start.size(); ++v)
      lum.setPoseMatrix(v, p.start[v]);
    for (const auto& [i, j] : p.links)
      lum.addLink(i, j);
    lum.compute();
    for (std::size_t v = 0; v < p.start.size(); ++v)
      Eigen::Matrix4d::Map(&flat[16 * v]) = lum.getPoseMatrix(v);
  }
  MPI_Bcast(flat.data(), static_cast<int>(flat.size()), MPI_DOUBLE, 0, MPI_COMM_WORLD);
  Poses out;
  for (std::size_t v = 0; v < p.start.size(); ++v)
    out.push_back(Eigen::Matrix4d::Map(&flat[16 * v]));
  return out;
}

/** The vertices of the links a rank owns (ParallelLUM's order: sorted pairs). */
std::vector<std::size_t>
ownedVertices(Links links, int rank)
{
  std::sort(links.begin(), links.end());
  const auto [begin, end] = pcl_parallel::mpi::linkRange(links.size(), rank, worldSize());
  std::set<std::size_t> v;
  for (std::size_t li = begin; li < end; ++li) {
    v.insert(links[li].first);
    v.insert(links[li].second);
  }
  return {v.begin(), v.end()};
}

void
expectIdenticalToOneProcess(const Problem& p, double gate)
{
  for (bool options : {false, true}) {
    const Poses ref = reference(p, options, gate, 1);
    for (unsigned threads : {1u, 2u}) {
      SCOPED_TRACE("options " + std::to_string(options) + ", threads per rank " +
                   std::to_string(threads) + ", ranks " + std::to_string(worldSize()));
      DistributedLUM d;
      d.lum().setNumberOfThreads(threads);
      configure(d.lum(), options, gate);
      std::vector<std::size_t> loaded;
      d.setGraph(p.start, p.links, [&](std::size_t v) {
        loaded.push_back(v);
        return p.load(v);
      });
      // Each rank reads only the scans of its own links.
      EXPECT_EQ(loaded, ownedVertices(p.links, worldRank()));
      EXPECT_EQ(d.getLoadedVertices(), loaded);
      d.compute();
      EXPECT_EQ(d.lum().getNumIterationsDone(), 3);
      bool moved = false;
      for (std::size_t v = 0; v < p.start.size(); ++v) {
        const Eigen::Matrix4d got = d.getPoseMatrix(v);
        moved = moved || got != p.start[v];
        for (int k = 0; k < 16; ++k)
          EXPECT_EQ(got(k), ref[v](k)) << "vertex " << v << ", entry " << k;
      }
      EXPECT_TRUE(moved); // the relaxation did something
      if (worldSize() > 1) {
        EXPECT_GT(d.getBytesPerIteration(), 0u);
      }
    }
  }
}

/** Eight poses on a loop (1 m apart, small rotations), scans of 400 points each per link
 *  around the two poses (test/common/synthetic_graph.h); start poses 1 deg / 1 cm off. */
Problem
syntheticProblem(std::vector<Cloud::Ptr>& clouds)
{
  Poses truth;
  for (int k = 0; k < 8; ++k) {
    const double a = 2.0 * M_PI * k / 8.0;
    Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
    t.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.05 * k, Eigen::Vector3d::UnitZ()).matrix();
    t.topRightCorner<3, 1>() = Eigen::Vector3d(1.3 * std::cos(a), 1.3 * std::sin(a), 0.0);
    truth.push_back(t);
  }
  std::vector<std::pair<std::uint32_t, std::uint32_t>> seen;
  for (std::uint32_t k = 0; k < 8; ++k)
    seen.emplace_back(k, (k + 1) % 8);
  seen.emplace_back(0, 4);
  seen.emplace_back(2, 6);
  const auto sg = pcl_parallel::test::makeGraph(truth, seen, 400, 0.6, 0.001, 5u);
  clouds = sg.clouds;
  std::mt19937 rng(17);
  Problem p;
  p.start = truth;
  for (std::size_t v = 1; v < truth.size(); ++v)
    p.start[v] = pcl_parallel::test::perturb(truth[v], 1.0 * kDeg, 0.01, rng);
  p.links = linksAtStart(clouds, p.start, 0.05, 0.1);
  p.load = [&clouds](std::size_t v) { return clouds[v]; };
  return p;
}

class QuietPcl : public ::testing::Test {
protected:
  void
  SetUp() override
  {
    pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
  }
};

TEST_F(QuietPcl, SyntheticLoopIsIdenticalToOneProcess)
{
  std::vector<Cloud::Ptr> clouds;
  const Problem p = syntheticProblem(clouds);
  ASSERT_GE(p.links.size(), 8u);
  expectIdenticalToOneProcess(p, 0.05);
}

// Three poses, two links: with 3 ranks one rank owns no link (and loads no scan).
TEST_F(QuietPcl, RankWithoutLinksIsIdenticalToOneProcess)
{
  const Poses truth = {
      Eigen::Matrix4d::Identity(),
      (Eigen::Matrix4d() << 1, 0, 0, 1, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1).finished(),
      (Eigen::Matrix4d() << 1, 0, 0, 2, 0, 1, 0, 0.2, 0, 0, 1, 0, 0, 0, 0, 1).finished()};
  const auto sg = pcl_parallel::test::makeGraph(truth, {{0, 1}, {1, 2}}, 400, 0.6, 0.001, 9u);
  std::mt19937 rng(3);
  Problem p;
  p.start = truth;
  for (std::size_t v = 1; v < truth.size(); ++v)
    p.start[v] = pcl_parallel::test::perturb(truth[v], 1.0 * kDeg, 0.01, rng);
  p.links = {{0, 1}, {1, 2}};
  p.load = [&sg](std::size_t v) { return sg.clouds[v]; };
  expectIdenticalToOneProcess(p, 0.05);
}

TEST_F(QuietPcl, BunnyIsIdenticalToOneProcess)
{
  PCL_PARALLEL_REQUIRE_DATA(conf, "stanford_bunny/bun.conf");
  const auto dir = std::filesystem::path(conf).parent_path();
  const auto entries = pcl_parallel::io::loadStanfordConf(conf);
  // Every 4th point of a scan, read from its file once (on the ranks that need it).
  std::map<std::size_t, Cloud::Ptr> read;
  auto load = [&](std::size_t v) {
    Cloud::Ptr& sub = read[v];
    if (!sub) {
      const Cloud::Ptr full =
          pcl_parallel::io::loadStanfordScan((dir / entries[v].file).string());
      sub.reset(new Cloud);
      for (std::size_t k = 0; k < full->size(); k += 4)
        sub->push_back((*full)[k]);
    }
    return sub;
  };
  std::vector<Cloud::Ptr> clouds; // rank 0 only: to choose the links
  Problem p;
  std::mt19937 rng(2007);
  for (const auto& e : entries) {
    p.start.push_back(
        p.start.empty() ? e.pose : pcl_parallel::test::perturb(e.pose, 2 * kDeg, 0.003, rng));
    if (worldRank() == 0)
      clouds.push_back(load(p.start.size() - 1));
  }
  p.links = linksAtStart(clouds, p.start, 0.01, 0.3);
  ASSERT_GE(p.links.size(), 10u);
  p.load = load;
  expectIdenticalToOneProcess(p, 0.01);
}

// A rank that cannot read one of its scans: every rank throws rank 0's message, which
// names the rank, the scan and the file; nobody hangs in a collective.
TEST_F(QuietPcl, UnreadableScanIsOneClearErrorOnEveryRank)
{
  std::vector<Cloud::Ptr> clouds;
  const Problem p = syntheticProblem(clouds);
  const int last = worldSize() - 1;
  const std::size_t bad = ownedVertices(p.links, last).back(); // the last rank's last scan
  DistributedLUM d;
  configure(d.lum(), false, 0.05);
  try {
    d.setGraph(p.start, p.links, [&](std::size_t v) {
      if (worldRank() == last && v == bad)
        return pcl_parallel::io::loadStanfordScan("/nonexistent/scan_for_test.ply");
      return clouds[v];
    });
    ADD_FAILURE() << "no exception";
  }
  catch (const std::runtime_error& e) {
    const std::string expect = "rank " + std::to_string(last) + " of " +
                               std::to_string(worldSize()) + ": scan " + std::to_string(bad) +
                               ": ";
    EXPECT_EQ(std::string(e.what()).rfind(expect, 0), 0u) << e.what();
    EXPECT_NE(std::string(e.what()).find("scan_for_test.ply"), std::string::npos) << e.what();
  }
  // The next collective call still works: the ranks stayed in step.
  d.setGraph(p.start, p.links, [&](std::size_t v) { return clouds[v]; });
  d.compute();
  EXPECT_EQ(d.lum().getNumIterationsDone(), 3);
}

TEST_F(QuietPcl, DifferentOptionsOnOneRankAreAnError)
{
  if (worldSize() < 2)
    GTEST_SKIP() << "needs 2 ranks";
  std::vector<Cloud::Ptr> clouds;
  const Problem p = syntheticProblem(clouds);
  DistributedLUM d;
  configure(d.lum(), false, worldRank() == 1 ? 0.04 : 0.05);
  d.setGraph(p.start, p.links, p.load);
  try {
    d.compute();
    ADD_FAILURE() << "no exception";
  }
  catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("differ between ranks"), std::string::npos)
        << e.what();
  }
}

TEST(DistributedLum, LinkRangesAreContiguousAndCoverAll)
{
  for (std::size_t n : {0u, 1u, 5u, 12u, 13u})
    for (int size : {1, 2, 3, 7}) {
      std::size_t next = 0;
      for (int r = 0; r < size; ++r) {
        const auto [b, e] = pcl_parallel::mpi::linkRange(n, r, size);
        EXPECT_EQ(b, next);
        EXPECT_LE(e - b, n / size + 1);
        EXPECT_GE(e - b, n / size);
        next = e;
      }
      EXPECT_EQ(next, n);
    }
}

/** --fail-load: the last rank cannot read a scan and nobody catches it: every rank ends
 *  with exit status 1, rank 0 printing the message. */
int
failLoad()
{
  pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
  std::vector<Cloud::Ptr> clouds;
  const Problem p = syntheticProblem(clouds);
  DistributedLUM d;
  configure(d.lum(), false, 0.05);
  try {
    d.setGraph(p.start, p.links, [&](std::size_t v) {
      if (worldRank() == worldSize() - 1)
        return pcl_parallel::io::loadStanfordScan("/nonexistent/scan_for_test.ply");
      return clouds[v];
    });
    d.compute();
  }
  catch (const std::exception& e) {
    if (worldRank() == 0)
      std::fprintf(stderr, "test_mpi_lum: %s\n", e.what());
    return 1;
  }
  return 0;
}

} // namespace

int
main(int argc, char** argv)
{
  int provided = 0;
  // OpenMP threads inside a rank; MPI is called from the main thread only.
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  int rc = 0;
  if (argc > 1 && std::strcmp(argv[1], "--fail-load") == 0)
    rc = failLoad();
  else {
    ::testing::InitGoogleTest(&argc, argv);
    rc = RUN_ALL_TESTS();
  }
  MPI_Finalize();
  return rc;
}
