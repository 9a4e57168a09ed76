/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/parallel.h>
#include <pcl_parallel/slam/read_ahead.h>

#include <optional>
#include <utility>

namespace pcl_parallel {
namespace slam {

ReadAhead::ReadAhead(ScanSource source, std::size_t num_scans, unsigned num_threads)
    : source_(std::move(source))
    , num_scans_(resolveNumberOfThreads(num_threads) > 1 ? num_scans : 0)
{}

ReadAhead::~ReadAhead()
{
  if (pending_.valid())
    pending_.wait(); // source_ (and what it refers to) must outlive its last call
}

SourceScan
ReadAhead::operator()(std::size_t k)
{
  std::optional<SourceScan> scan;
  if (pending_.valid()) {
    // Waited for even when it is not scan k: source_ is never called twice at once.
    std::future<SourceScan> pending = std::move(pending_);
    if (next_ == k)
      scan = pending.get(); // rethrows what reading scan k threw
    else
      pending.wait(); // read out of turn: what was read ahead (or thrown) is dropped
  }
  if (!scan)
    scan = source_(k);
  if (k + 1 < num_scans_) {
    next_ = k + 1;
    pending_ = std::async(std::launch::async, [this, k] { return source_(k + 1); });
  }
  return std::move(*scan);
}

} // namespace slam
} // namespace pcl_parallel
