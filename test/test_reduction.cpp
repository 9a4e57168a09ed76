/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * The reduction every sum over points goes through (reduction.h): fixed blocks whatever
 * the thread count, folded in block order, so results are bit-identical for any thread
 * count; and a source of a downsampled scan's size (~10^3 points) is still reduced in
 * parallel.
 */
#include <pcl_parallel/reduction.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <gtest/gtest.h>
#include <thread>
#include <utility>
#include <vector>

namespace {

using pcl_parallel::deterministicBlocks;
using pcl_parallel::deterministicReduce;
using pcl_parallel::kReductionBlockSize;
using Range = std::pair<std::size_t, std::size_t>;

const unsigned kThreadCounts[] = {1u, 2u, 3u, 4u, 8u};

// Each block is one fixed range: [b * size, min(n, (b + 1) * size)), in block order,
// covering [0, n) once, for any thread count and any n (empty, one short of a block, ...).
TEST(Reduction, BlocksAreFixedRangesInOrder)
{
  for (const std::size_t n : {std::size_t(0),
                              std::size_t(1),
                              kReductionBlockSize - 1,
                              kReductionBlockSize,
                              kReductionBlockSize + 1,
                              std::size_t(1000),
                              std::size_t(12345)}) {
    std::vector<Range> expected;
    for (std::size_t b = 0; b < n; b += kReductionBlockSize)
      expected.emplace_back(b, std::min(n, b + kReductionBlockSize));
    for (const unsigned threads : kThreadCounts) {
      const std::vector<Range> got =
          deterministicBlocks(n, threads, Range{}, [](std::size_t begin, std::size_t end) {
            return Range{begin, end};
          });
      EXPECT_EQ(got, expected) << n << " elements, " << threads << " threads";
    }
  }
}

// Values whose float sum depends on the order of the additions (1e8 swallows a 1 added
// to it, not 1s added first): the result is the same bit for bit on every thread count,
// and is the fold of the blocks in block order.
TEST(Reduction, SumIsBitIdenticalForAnyThreadCount)
{
  const std::size_t n = 10007;
  std::vector<float> v(n);
  for (std::size_t i = 0; i < n; ++i)
    v[i] = i % 997 == 0 ? 1e8f : (i % 3 == 0 ? 1.0f : 0.3f + 1e-4f * static_cast<float>(i));
  const auto block = [&](std::size_t begin, std::size_t end) {
    float s = 0.0f;
    for (std::size_t i = begin; i < end; ++i)
      s += v[i];
    return s;
  };
  const auto add = [](float& into, float from) { into += from; };
  float serial = 0.0f;
  for (std::size_t b = 0; b < n; b += kReductionBlockSize)
    serial += block(b, std::min(n, b + kReductionBlockSize));
  for (const unsigned threads : kThreadCounts) {
    const float got = deterministicReduce(n, threads, 0.0f, block, add);
    EXPECT_EQ(got, serial) << threads << " threads"; // exact: same additions, same order
  }
}

// A downsampled scan's source (10^3 points: KISS-ICP-style sources, mulran's keyframes)
// spans several blocks, so the reduction is shared by every thread asked for, not run on
// one (with 2,048-point blocks it was one block, run serially). Each block waits for a
// second thread to show up (bounded), so the test sees the sharing without timing it.
TEST(Reduction, ThousandPointSourceRunsInParallel)
{
  std::atomic<unsigned> seen{0}; // bit s: slot s took a block
  const std::vector<unsigned> got =
      deterministicBlocks(1000, 2, 0u, [&](std::size_t, std::size_t, unsigned slot) {
        seen |= 1u << slot;
        for (int i = 0; i < 10000 && seen.load() != 3u; ++i)
          std::this_thread::sleep_for(std::chrono::microseconds(500));
        return slot;
      });
  ASSERT_GE(got.size(), 4u);
  for (const unsigned slot : got)
    EXPECT_LT(slot, 2u);
  EXPECT_EQ(seen.load(), 3u) << "one thread took every block";
}

} // namespace
