/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
// slam::ReadAhead: the scans it hands out are the source's, in any order; the source is
// never called twice at once, never for a scan past the end, at most one scan ahead; a
// read's exception reaches the caller with that scan; on one thread nothing is read ahead.
#include <pcl_parallel/slam/read_ahead.h>

#include <atomic>
#include <chrono>
#include <gtest/gtest.h>
#include <stdexcept>
#include <thread>
#include <vector>

namespace {

using pcl_parallel::slam::ReadAhead;
using pcl_parallel::slam::SourceScan;

/** A source whose scan k is one point at x = k, stamped k; it records what it was asked
 *  for and how many reads ran at once, and sleeps a little so that reads overlap the
 *  caller's work. */
struct RecordingSource {
  std::vector<std::size_t> asked; ///< read by the test once the reads are done
  std::atomic<std::size_t> calls{0};
  std::atomic<int> running{0};
  int most_running = 0;
  std::size_t throw_at = static_cast<std::size_t>(-1);

  SourceScan
  operator()(std::size_t k)
  {
    ++calls;
    const int now = ++running;
    most_running = std::max(most_running, now);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    asked.push_back(k);
    --running;
    if (k == throw_at)
      throw std::runtime_error("scan " + std::to_string(k) + ": unreadable");
    SourceScan s;
    s.cloud.reset(new pcl_parallel::slam::Cloud);
    s.cloud->push_back(pcl::PointXYZ(static_cast<float>(k), 0.0f, 0.0f));
    s.stamp = static_cast<double>(k);
    return s;
  }
};

float
scanId(const SourceScan& s)
{
  return s.cloud->front().x;
}

} // namespace

TEST(ReadAhead, HandsOutEachScanInTurnReadingOneAhead)
{
  RecordingSource source;
  const std::size_t n = 6;
  {
    ReadAhead read([&](std::size_t k) { return source(k); }, n, 2);
    for (std::size_t k = 0; k < n; ++k) {
      const SourceScan s = read(k);
      EXPECT_EQ(scanId(s), static_cast<float>(k));
      EXPECT_EQ(*s.stamp, static_cast<double>(k));
      std::this_thread::sleep_for(std::chrono::milliseconds(3)); // the caller's work
      EXPECT_LE(source.calls, k + 2) << "read more than one scan ahead";
    }
  }
  // Each scan read once, in order, none past the end, one read at a time.
  EXPECT_EQ(source.asked, (std::vector<std::size_t>{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(source.most_running, 1);
}

TEST(ReadAhead, ScansAskedOutOfTurnAreReadThen)
{
  RecordingSource source;
  ReadAhead read([&](std::size_t k) { return source(k); }, 10, 2);
  for (const std::size_t k : {3u, 4u, 0u, 9u, 9u, 5u})
    EXPECT_EQ(scanId(read(k)), static_cast<float>(k));
  EXPECT_EQ(source.most_running, 1);
}

TEST(ReadAhead, AReadsErrorReachesTheCallerWithThatScan)
{
  RecordingSource source;
  source.throw_at = 2;
  ReadAhead read([&](std::size_t k) { return source(k); }, 5, 2);
  EXPECT_EQ(scanId(read(0)), 0.0f);
  EXPECT_EQ(scanId(read(1)), 1.0f); // scan 2 fails in the background: not yet an error
  try {
    read(2);
    FAIL() << "scan 2's read error was lost";
  }
  catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "scan 2: unreadable");
  }
  EXPECT_EQ(scanId(read(3)), 3.0f); // the caller may go on past it
}

TEST(ReadAhead, DestroyedWithAReadInFlightWaitsForIt)
{
  RecordingSource source;
  {
    ReadAhead read([&](std::size_t k) { return source(k); }, 3, 2);
    read(0); // starts reading scan 1, then goes out of scope
  }
  EXPECT_EQ(source.running, 0);
  EXPECT_EQ(source.asked, (std::vector<std::size_t>{0, 1}));
}

TEST(ReadAhead, OnOneThreadEveryScanIsReadOnTheCallersThread)
{
  RecordingSource source;
  const std::thread::id caller = std::this_thread::get_id();
  std::vector<std::thread::id> readers;
  ReadAhead read(
      [&](std::size_t k) {
        readers.push_back(std::this_thread::get_id());
        return source(k);
      },
      4,
      1);
  for (std::size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(scanId(read(k)), static_cast<float>(k));
    EXPECT_EQ(source.calls, k + 1) << "read ahead on one thread";
  }
  EXPECT_EQ(readers, std::vector<std::thread::id>(4, caller));
}
