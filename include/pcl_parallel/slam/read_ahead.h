/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/segments.h>

#include <cstddef>
#include <future>

namespace pcl_parallel {
namespace slam {

/**
 * \brief A ScanSource that reads scan k + 1 on a thread of its own while the caller maps
 * scan k: reading a file is serial work (milliseconds per scan), which then
 * overlaps the front end's instead of adding to it (docs/design.md, "Serial work per
 * scan").
 *
 * Scans are asked for in any order; one asked for out of turn is read then, on the
 * caller's thread. `source` is called for one scan at a time, never concurrently, so it
 * may keep state; its exceptions reach the caller when that scan is asked for. At most one
 * scan more than the caller holds is in memory. The destructor waits for a read in flight.
 */
class ReadAhead {
public:
  /** Reads ahead up to scan num_scans - 1. With one thread (num_threads, 0 = all cores)
   *  it never does: every scan is read on the caller's thread, which is then the only one. */
  ReadAhead(ScanSource source, std::size_t num_scans, unsigned num_threads = 0);
  ~ReadAhead();
  ReadAhead(const ReadAhead&) = delete;
  ReadAhead&
  operator=(const ReadAhead&) = delete;

  /** Scan k (source(k)); then starts reading k + 1 if k + 1 < num_scans (and more than
   *  one thread). */
  SourceScan
  operator()(std::size_t k);

private:
  ScanSource source_;
  std::size_t num_scans_; ///< 0 with one thread: nothing read ahead
  std::size_t next_ = 0;  ///< the scan `pending_` reads, if valid
  std::future<SourceScan> pending_;
};

} // namespace slam
} // namespace pcl_parallel
