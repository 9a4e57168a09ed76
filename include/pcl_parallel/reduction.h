/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/parallel.h>

#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <utility>
#include <vector>

namespace pcl_parallel {

/** Elements per block of deterministicReduce(): large enough that a block's work (a
 *  nearest-neighbour query each, ~0.1 ms a block) dwarfs taking it and combining it,
 *  small enough that the ~10^3-point sources of a downsampled scan still make several
 *  blocks per thread (a source of one block runs on one thread). */
constexpr std::size_t kReductionBlockSize = 256;

/**
 * \brief The map half of deterministicReduce(): [0, n) cut into fixed blocks of
 * \a block_size, `Acc block(std::size_t begin, std::size_t end)` (or with a third
 * argument, parallelFor()'s slot, for per-thread scratch state) run on each block by
 * whichever thread takes it, the results returned in block order. What a block computes
 * depends only on its range, never on the thread count. Use it directly when the
 * combination is not a plain fold (e.g. pICP's Eq. 12 needs every block's centroid).
 */
template <typename Acc, typename BlockFn>
std::vector<Acc>
deterministicBlocks(std::size_t n,
                    unsigned num_threads,
                    const Acc& identity,
                    BlockFn&& block,
                    std::size_t block_size = kReductionBlockSize)
{
  // Block results in cache-line padded slots so no two threads write to one line.
  struct alignas(kCacheLineSize) Slot {
    Acc value;
  };
  if (block_size == 0)
    block_size = kReductionBlockSize;
  const std::size_t blocks = (n + block_size - 1) / block_size;
  std::vector<Slot> partial(blocks, Slot{identity});
  parallelFor(blocks, num_threads, 1, [&](std::size_t first, std::size_t last, unsigned slot) {
    for (std::size_t b = first; b < last; ++b) {
      const std::size_t begin = b * block_size;
      const std::size_t end = begin + block_size < n ? begin + block_size : n;
      if constexpr (std::is_invocable_v<BlockFn&, std::size_t, std::size_t, unsigned>)
        partial[b].value = block(begin, end, slot);
      else
        partial[b].value = block(begin, end);
    }
  });
  std::vector<Acc> out;
  out.reserve(blocks);
  for (Slot& s : partial)
    out.push_back(std::move(s.value));
  return out;
}

/**
 * \brief Thread-count independent parallel reduction.
 *
 * deterministicBlocks() reduces each fixed block on its own; the block results are then
 * folded in block order by `void combine(Acc& into, const Acc& from)`. Neither the
 * grouping nor the order of floating-point operations depends on the number of threads,
 * so the result is bit-identical for any thread count.
 */
template <typename Acc, typename BlockFn, typename CombineFn>
Acc
deterministicReduce(std::size_t n,
                    unsigned num_threads,
                    const Acc& identity,
                    BlockFn&& block,
                    CombineFn&& combine,
                    std::size_t block_size = kReductionBlockSize)
{
  const std::vector<Acc> partial =
      deterministicBlocks(n, num_threads, identity, block, block_size);
  Acc total = identity;
  for (const Acc& a : partial)
    combine(total, a);
  return total;
}

} // namespace pcl_parallel
