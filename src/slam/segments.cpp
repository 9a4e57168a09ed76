/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/slam/preprocess.h>
#include <pcl_parallel/slam/read_ahead.h>
#include <pcl_parallel/slam/segments.h>

#include <algorithm>
#include <functional>
#include <stdexcept>
#include <string>
#include <utility>

namespace pcl_parallel {
namespace slam {

std::vector<Segment>
splitSequence(std::size_t num_scans, std::size_t segment_size, std::size_t overlap)
{
  if (segment_size == 0)
    throw std::invalid_argument("splitSequence: segment size must be at least 1");
  if (overlap == 0 && num_scans > segment_size) // the join is the match of the overlap
    throw std::invalid_argument("splitSequence: segments need an overlap of at least 1 scan");
  std::vector<Segment> out;
  for (std::size_t begin = 0; begin < num_scans; begin += segment_size) {
    Segment s;
    s.begin = begin;
    s.first = begin - std::min(begin, overlap);
    s.end = std::min(num_scans, begin + segment_size);
    out.push_back(s);
  }
  return out;
}

double
sequenceMedianRange(const Cloud& first_scan, const Parameters& params)
{
  const Cloud::Ptr cropped = cropRange(
      first_scan, params.reduction.min_range, params.reduction.max_range, params.num_threads);
  requirePointsInRange(*cropped, 0);
  return medianRange(*cropped);
}

double
sequenceMedianRange(ScanSource& read, const Parameters& params)
{
  SourceScan first = read(0);
  if (!first.cloud)
    throw std::invalid_argument("scan 0 could not be read");
  const double range = sequenceMedianRange(*first.cloud, params);
  read = [first = std::move(first), read = std::move(read)](std::size_t i) mutable {
    if (i == 0 && first.cloud)
      return std::exchange(first, {});
    return read(i);
  };
  return range;
}

std::vector<ScanRecord>
matchSegment(const Segment& segment,
             const Parameters& params,
             double median_range,
             const ScanSource& read,
             const std::function<void(std::size_t)>& matched,
             StageTimes* times)
{
  Pipeline front_end(params, median_range, segment.first);
  std::vector<ScanRecord> own;
  own.reserve(segment.end - segment.begin);
  // The segment is mapped as the online pipeline maps a sequence: its own loops closed as
  // they come, the front end continuing from the corrected poses.
  const auto add = [&](std::vector<ScanRecord> records) {
    for (ScanRecord& r : records) {
      if (r.index >= segment.begin)
        own.push_back(r);
      front_end.addTracked(std::move(r));
    }
  };
  // The segment's next scan read while one is matched.
  ReadAhead ahead(std::cref(read), segment.end, params.num_threads);
  for (std::size_t i = segment.first; i < segment.end; ++i) {
    const SourceScan scan = ahead(i);
    if (!scan.cloud)
      throw std::invalid_argument("scan " + std::to_string(i) + " could not be read");
    add(front_end.track(*scan.cloud, scan.odometry, scan.stamp, scan.point_times));
    if (matched)
      matched(i - segment.first + 1);
  }
  add(front_end.drain());
  if (times)
    times->add(front_end.times());
  return own;
}

std::unique_ptr<Pipeline>
mapSegments(const Parameters& params,
            std::size_t num_scans,
            std::size_t segment_size,
            std::size_t overlap,
            const ScanSource& source,
            const SegmentProgress& progress)
{
  if (num_scans == 0)
    throw std::invalid_argument("mapSegments: no scans");
  ScanSource read = source;
  const double range = sequenceMedianRange(read, params);
  std::unique_ptr<Pipeline> pipeline(new Pipeline(params, range));
  // All front ends first, then loop closing: the order mpi::mapSegments has.
  const std::vector<Segment> segments = splitSequence(num_scans, segment_size, overlap);
  std::size_t total = 0, done = 0;
  for (const Segment& s : segments)
    total += s.end - s.first;
  StageTimes times;
  std::vector<ScanRecord> matched;
  matched.reserve(num_scans);
  for (const Segment& s : segments) {
    auto step = [&](std::size_t k) {
      if (progress)
        progress("match", done + k, total);
    };
    for (ScanRecord& m : matchSegment(s, params, range, read, step, &times))
      matched.push_back(std::move(m));
    done += s.end - s.first;
  }
  for (ScanRecord& m : matched) {
    pipeline->addMatched(std::move(m));
    if (progress)
      progress("join", pipeline->size(), num_scans);
  }
  pipeline->addTimes(times);
  return pipeline;
}

} // namespace slam
} // namespace pcl_parallel
