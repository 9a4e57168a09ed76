/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The mapping pipeline over MPI ranks (mpi::mapSegments), run by mpiexec with 1, 2 and 3
 * ranks (test/CMakeLists.txt): bit-identical to slam::mapSegments in one process for any
 * rank and thread count, a scan one rank cannot read ends every rank with one message,
 * options that differ between ranks are an error.
 */
#include "corridor_set.h"
#include "mpi_test.h"

#include <pcl_parallel/mpi/pipeline.h>

#include <pcl/console/print.h>

#include <algorithm>
#include <gtest/gtest.h>
#include <stdexcept>
#include <string>

namespace {

using namespace pcl_parallel;

using test::corridorSet;
using test::worldRank;
using test::worldSize;

slam::ScanSource
source(const sim::SimulatedScanSet& set)
{
  return [&set](std::size_t i) {
    return slam::SourceScan{set.scans[i], set.odometry[i], std::nullopt, {}};
  };
}

constexpr std::size_t kSegmentSize = 10, kOverlap = 3;

TEST(MapSegments, BitIdenticalToOneProcessForAnyRankAndThreadCount)
{
  const auto& set = corridorSet();
  const std::size_t n = set.scans.size();
  slam::Parameters p;
  p.num_threads = 2;
  auto alone = slam::mapSegments(p, n, kSegmentSize, kOverlap, source(set));
  alone->finish();
  ASSERT_GT(alone->links().size(), n - 1) << "no loop link: pLUM over ranks is not tested";
  for (unsigned threads : {1u, 2u}) {
    p.num_threads = (threads + static_cast<unsigned>(worldRank())) % 2 + 1; // varies by rank
    mpi::SegmentsReport report;
    auto ranks =
        mpi::mapSegments(MPI_COMM_WORLD, p, n, kSegmentSize, kOverlap, source(set), &report);
    ranks->finish();
    ASSERT_EQ(ranks->size(), n);
    for (std::size_t i = 0; i < n; ++i)
      for (int k = 0; k < 16; ++k) {
        ASSERT_EQ(ranks->poses()[i](k), alone->poses()[i](k)) << "scan " << i;
        ASSERT_EQ(ranks->frontEndPoses()[i](k), alone->frontEndPoses()[i](k)) << "scan " << i;
      }
    ASSERT_EQ(ranks->links().size(), alone->links().size());
    for (std::size_t l = 0; l < alone->links().size(); ++l) {
      EXPECT_EQ(ranks->links()[l].source, alone->links()[l].source);
      EXPECT_EQ(ranks->links()[l].target, alone->links()[l].target);
    }
    for (std::size_t i = 0; i < n; ++i)
      EXPECT_EQ(ranks->reports()[i].sequence_chi2, alone->reports()[i].sequence_chi2);
    // The segments are spread: every scan matched as its own by exactly one rank.
    unsigned long own = report.own_scans, all = 0;
    MPI_Allreduce(&own, &all, 1, MPI_UNSIGNED_LONG, MPI_SUM, MPI_COMM_WORLD);
    EXPECT_EQ(all, n);
    EXPECT_EQ(report.segments, (n + kSegmentSize - 1) / kSegmentSize);
    const auto [b, e] = mpi::scansOfRank(n, kSegmentSize, worldRank(), worldSize());
    EXPECT_EQ(e - b, report.own_scans);
    // A rank keeps the points of its own scans and of the other scans its links need
    // (each link is measured where its newer scan is kept): no more.
    std::vector<char> needed(n, 0);
    std::size_t crossing = 0; // links whose two scans are on different ranks
    const auto mine = [b = b, e = e](std::size_t i) { return b <= i && i < e; };
    for (std::size_t i = 0; i < n; ++i)
      needed[i] = mine(i);
    for (const auto& l : alone->links()) {
      needed[l.target] |= mine(l.source);
      const auto owner = [&](std::size_t i) {
        for (int r = 0; r < worldSize(); ++r) {
          const auto range = mpi::scansOfRank(n, kSegmentSize, r, worldSize());
          if (range.first <= i && i < range.second)
            return r;
        }
        return -1;
      };
      crossing += owner(l.source) != owner(l.target) ? 1 : 0;
    }
    const std::size_t expect_kept = std::count(needed.begin(), needed.end(), 1);
    EXPECT_EQ(report.kept_scans, expect_kept);
    EXPECT_EQ(ranks->keptScans(), expect_kept);
    if (worldSize() > 1) {
      EXPECT_LT(report.kept_scans, n) << "a rank holds the whole survey";
    }
    for (std::size_t i = 0; i < n; ++i) {
      ASSERT_EQ(static_cast<bool>(ranks->reducedScan(i)), mine(i)) << "scan " << i;
      if (mine(i)) { // the same points as in one process
        const auto& got = *ranks->reducedScan(i);
        const auto& want = *alone->reducedScan(i);
        ASSERT_EQ(got.size(), want.size());
        for (std::size_t k = 0; k < got.size(); ++k)
          ASSERT_EQ(got[k].getVector3fMap(), want[k].getVector3fMap());
      }
    }
    // Counts are all ranks' (the same on each): a scan travels at least once per link
    // across ranks, and far fewer bytes than every scan's points and normals (24 B a
    // point) to every rank.
    std::uint64_t points = 0, lo = 0, hi = 0;
    for (std::size_t i = 0; i < n; ++i)
      points += alone->reducedScan(i)->size();
    MPI_Allreduce(&report.bytes_shared, &lo, 1, MPI_UINT64_T, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(&report.bytes_shared, &hi, 1, MPI_UINT64_T, MPI_MAX, MPI_COMM_WORLD);
    EXPECT_EQ(lo, hi);
    EXPECT_GE(report.scans_sent, crossing);
    if (worldSize() == 1) {
      EXPECT_EQ(report.bytes_shared, 0u);
    }
    else {
      EXPECT_GT(report.scans_sent, 0u);
      EXPECT_LT(report.bytes_shared, points * 24);
    }
  }
}

TEST(MapSegments, AScanOneRankCannotReadEndsEveryRankWithOneMessage)
{
  const auto& set = corridorSet();
  const std::size_t n = set.scans.size();
  const auto good = source(set);
  const int last = worldSize() - 1;
  const slam::ScanSource bad = [&](std::size_t i) {
    if (worldRank() == last && i == n - 1)
      throw std::runtime_error("/data/scan_for_test.bin: cannot open");
    return good(i);
  };
  slam::Parameters p;
  p.num_threads = 1;
  try {
    mpi::mapSegments(MPI_COMM_WORLD, p, n, kSegmentSize, kOverlap, bad);
    ADD_FAILURE() << "no exception";
  }
  catch (const std::runtime_error& e) {
    const std::string expect = "rank " + std::to_string(last) + " of " +
                               std::to_string(worldSize()) +
                               ": /data/scan_for_test.bin: cannot open";
    EXPECT_EQ(std::string(e.what()), expect);
  }
  // The ranks stayed in step: the next collective call works.
  slam::Parameters q;
  q.num_threads = 1;
  q.loops.enabled = false;
  EXPECT_EQ(mpi::mapSegments(MPI_COMM_WORLD, q, 6, 3, 1, good)->size(), 6u);
}

TEST(MapSegments, DifferentOptionsOnOneRankAreAnError)
{
  if (worldSize() < 2)
    GTEST_SKIP() << "needs 2 ranks";
  slam::Parameters p;
  p.reduction.voxel_size = worldRank() == 1 ? 0.2 : 0.25;
  try {
    mpi::mapSegments(MPI_COMM_WORLD, p, 6, 3, 1, source(corridorSet()));
    ADD_FAILURE() << "no exception";
  }
  catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("differ between ranks"), std::string::npos)
        << e.what();
  }
}

TEST(MapSegments, ScansOfRankAreContiguousAndCoverAll)
{
  for (std::size_t n : {1u, 7u, 38u})
    for (std::size_t segment : {1u, 4u, 10u, 50u})
      for (int size : {1, 2, 3, 5}) {
        std::size_t next = 0;
        for (int r = 0; r < size; ++r) {
          const auto [b, e] = mpi::scansOfRank(n, segment, r, size);
          if (b == e)
            continue; // a rank without a segment
          EXPECT_EQ(b, next) << n << " " << segment << " " << size;
          next = e;
        }
        EXPECT_EQ(next, n);
      }
}

} // namespace

int
main(int argc, char** argv)
{
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  pcl::console::setVerbosityLevel(pcl::console::L_ERROR);
  ::testing::InitGoogleTest(&argc, argv);
  // One report (rank 0's); every rank still runs every test (they are collective).
  if (worldRank() != 0)
    delete ::testing::UnitTest::GetInstance()->listeners().Release(
        ::testing::UnitTest::GetInstance()->listeners().default_result_printer());
  int rc = RUN_ALL_TESTS();
  MPI_Allreduce(MPI_IN_PLACE, &rc, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
  MPI_Finalize();
  return rc;
}
