/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_parallel/slam/pipeline.h>

#include <functional>
#include <memory>
#include <optional>
#include <utility>
#include <vector>

namespace pcl_parallel {
namespace slam {

/**
 * \brief A contiguous part of a sequence matched by a front end of its own (the
 * segmented front end, docs/design.md "Segments"): scans [first, end) are matched,
 * [begin, end) are its own; the `begin - first` scans before are the previous segment's
 * last ones, matched again so that the first own scan meets a local map and a motion
 * estimate instead of a cold start.
 */
struct Segment {
  /** The segment's first (overlap) scan and its own scans [begin, end). */
  ///@{
  std::size_t first = 0, begin = 0, end = 0;
  ///@}
};

/** Segments of `segment_size` own scans (the last takes the rest), each starting
 *  `overlap` scans before its first own one. Throws std::invalid_argument for
 *  segment_size 0, or overlap 0 with more than one segment (a segment joins its
 *  predecessor through the overlap). */
std::vector<Segment>
splitSequence(std::size_t num_scans, std::size_t segment_size, std::size_t overlap);

/** A scan of a sequence (scanner frame) with its odometry pose, time stamp (s) and
 *  per-point times, if known (as Pipeline::addScan takes them). */
struct SourceScan {
  /** The scan (scanner frame). */
  Cloud::Ptr cloud;
  /** Its odometry pose, if any. */
  std::optional<Pose> odometry;
  /** Its time stamp (s), if any. */
  std::optional<double> stamp;
  /** Per-point times, or empty. */
  std::vector<double> point_times;
};

/** Scan i of a sequence; throws on a scan that cannot be read. */
using ScanSource = std::function<SourceScan(std::size_t)>;

/** The median range that sets a sequence's automatic lengths: scan 0's, after cropping
 *  (as Pipeline::addScan takes it). Throws std::invalid_argument if none is in range. */
double
sequenceMedianRange(const Cloud& first_scan, const Parameters& params);
/** ... read through `read`, which then hands that scan on once rather than reading it
 *  again (the first segment starts with it). Throws if scan 0 cannot be read. */
double
sequenceMedianRange(ScanSource& read, const Parameters& params);

/** Progress of a segmented run: stage ("match" for the front ends, "join" for loop
 *  closing), scans done, of total. */
using SegmentProgress =
    std::function<void(const char* stage, std::size_t done, std::size_t total)>;

/** Maps one segment as Pipeline::addScan maps a sequence (its own loops closed as they
 *  come, the front end continuing from the corrected poses), from its first scan's
 *  odometry pose (the identity without odometry), and returns its own scans as the front
 *  end matched them; each one's step joins it to its predecessor, the last scan of the
 *  previous segment for the first. `matched` is called after each scan with the scans
 *  matched so far; `times` gets the segment's stage times added. */
std::vector<ScanRecord>
matchSegment(const Segment& segment,
             const Parameters& params,
             double median_range,
             const ScanSource& read,
             const std::function<void(std::size_t)>& matched = {},
             StageTimes* times = nullptr);

/** Maps scans [0, num_scans) in this process as mpi::mapSegments does over ranks: each
 *  segment's front end in turn, then loop closing over the whole sequence (the segments
 *  joined by their steps, Pipeline::addMatched), with the lengths from scan 0
 *  (sequenceMedianRange). finish() is left to the caller. */
std::unique_ptr<Pipeline>
mapSegments(const Parameters& params,
            std::size_t num_scans,
            std::size_t segment_size,
            std::size_t overlap,
            const ScanSource& read,
            const SegmentProgress& progress = {});

} // namespace slam
} // namespace pcl_parallel
