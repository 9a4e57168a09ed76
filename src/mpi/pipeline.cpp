/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/mpi/pipeline.h>

#include <pcl/common/time.h>

#include <algorithm>
#include <climits>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace pcl_parallel {
namespace mpi {

namespace {

/** Matched scans as bytes: plain values in this machine's representation (the ranks of
 *  one job run one binary), floats and doubles bit for bit. */
class Writer {
public:
  template <typename T>
  void
  put(const T& value)
  {
    static_assert(std::is_trivially_copyable<T>::value, "plain values only");
    const char* p = reinterpret_cast<const char*>(&value);
    bytes_.insert(bytes_.end(), p, p + sizeof(T));
  }
  template <typename Derived>
  void
  putMatrix(const Eigen::MatrixBase<Derived>& m)
  {
    for (Eigen::Index k = 0; k < m.size(); ++k)
      put(m(k));
  }
  std::vector<char>&
  bytes()
  {
    return bytes_;
  }

private:
  std::vector<char> bytes_;
};

class Reader {
public:
  explicit Reader(const std::vector<char>& bytes)
      : p_(bytes.data())
      , end_(bytes.data() + bytes.size())
  {}
  template <typename T>
  T
  get()
  {
    if (static_cast<std::size_t>(end_ - p_) < sizeof(T))
      throw std::runtime_error("mpi::mapSegments: truncated message");
    T value;
    std::memcpy(&value, p_, sizeof(T));
    p_ += sizeof(T);
    return value;
  }
  template <typename Derived>
  void
  getMatrix(Eigen::MatrixBase<Derived>& m)
  {
    for (Eigen::Index k = 0; k < m.size(); ++k)
      m(k) = get<typename Derived::Scalar>();
  }

private:
  const char* p_;
  const char* end_;
};

void
writePoints(Writer& w, const slam::Cloud& points, const std::vector<Eigen::Vector3f>& normals)
{
  w.put<std::uint64_t>(points.size());
  for (const auto& p : points)
    w.put(p.x), w.put(p.y), w.put(p.z);
  w.put<std::uint64_t>(normals.size());
  for (const auto& n : normals)
    w.putMatrix(n);
}

/** A matched scan without its points and normals (the owner keeps those). */
void
writeMatched(Writer& w, const slam::ScanRecord& m)
{
  w.put<std::uint64_t>(m.index);
  w.putMatrix(m.pose);
  w.putMatrix(m.prediction);
  w.putMatrix(m.step);
  w.putMatrix(m.information);
  w.put(m.information_pairs);
  const slam::ScanReport& r = m.report;
  w.put(r.map_scans);
  w.put<std::uint64_t>(r.source_points);
  w.put<std::uint8_t>(r.converged);
  w.put(r.fitness);
  w.put(r.gate);
  w.put(r.start_offset);
  w.put(r.start_turn);
  w.put<std::uint8_t>(r.pose_searched);
  w.put<std::uint8_t>(r.deskewed_again);
  w.put(r.start_heading);
  w.put<std::uint64_t>(r.points);
  w.put<std::uint64_t>(r.reduced_points);
  w.put(r.correction);
  w.put(r.predicted_step);
  w.put(r.seconds);
}

slam::Cloud::Ptr
readPoints(Reader& in, std::vector<Eigen::Vector3f>& normals)
{
  slam::Cloud::Ptr points(new slam::Cloud);
  points->resize(in.get<std::uint64_t>());
  for (auto& p : *points) {
    p.x = in.get<float>();
    p.y = in.get<float>();
    p.z = in.get<float>();
  }
  normals.resize(in.get<std::uint64_t>());
  for (auto& n : normals)
    in.getMatrix(n);
  return points;
}

slam::ScanRecord
readMatched(Reader& in)
{
  slam::ScanRecord m;
  m.index = in.get<std::uint64_t>();
  in.getMatrix(m.pose);
  in.getMatrix(m.prediction);
  in.getMatrix(m.step);
  in.getMatrix(m.information);
  m.information_pairs = in.get<double>();
  slam::ScanReport& r = m.report;
  r.map_scans = in.get<double>();
  r.source_points = in.get<std::uint64_t>();
  r.converged = in.get<std::uint8_t>() != 0;
  r.fitness = in.get<double>();
  r.gate = in.get<double>();
  r.start_offset = in.get<double>();
  r.start_turn = in.get<double>();
  r.pose_searched = in.get<std::uint8_t>() != 0;
  r.deskewed_again = in.get<std::uint8_t>() != 0;
  r.start_heading = in.get<double>();
  r.points = in.get<std::uint64_t>();
  r.reduced_points = in.get<std::uint64_t>();
  r.correction = in.get<double>();
  r.predicted_step = in.get<double>();
  r.seconds = in.get<double>();
  return m;
}

/** Broadcasts `bytes` from `root` (resized on the others), in pieces MPI's int counts
 *  can hold. */
void
broadcastBytes(MPI_Comm comm, int root, std::vector<char>& bytes)
{
  std::uint64_t size = bytes.size();
  MPI_Bcast(&size, 1, MPI_UINT64_T, root, comm);
  bytes.resize(size);
  constexpr std::size_t kPiece = std::size_t(1) << 30;
  for (std::size_t at = 0; at < size; at += kPiece)
    MPI_Bcast(bytes.data() + at,
              static_cast<int>(std::min<std::size_t>(kPiece, size - at)),
              MPI_BYTE,
              root,
              comm);
}

/** Hash of everything that must be the same on every rank (all but the thread count). */
std::uint64_t
inputHash(const slam::Parameters& p,
          std::size_t num_scans,
          std::size_t segment_size,
          std::size_t overlap)
{
  Fnv1a h;
  const slam::ReductionParameters& r = p.reduction;
  h.add(r.min_range), h.add(r.max_range), h.add(r.voxel_size), h.add(r.source_voxel_size);
  h.add(p.deskew.enabled), h.add(p.deskew.sweep_period), h.add(p.deskew.sweep_clockwise);
  const slam::MatcherParameters& m = p.matcher;
  h.add(static_cast<int>(m.target)), h.add(m.max_correspondence_distance);
  h.add(m.final_correspondence_distance), h.add(m.max_iterations);
  h.add(m.transformation_epsilon), h.add(m.point_to_plane), h.add(m.normals_from_map);
  h.add(m.adaptive_threshold), h.add(m.motion_prior), h.add(m.map_distance);
  h.add(m.map_voxel_size), h.add(m.map_points_per_voxel);
  const slam::PoseGuessParameters& g = p.guess;
  h.add(g.guess_from_previous_scan), h.add(g.speed_hypotheses), h.add(g.pose_search);
  h.add(g.up.x()), h.add(g.up.y()), h.add(g.up.z());
  const slam::LoopClosureParameters& l = p.loops;
  h.add(l.enabled), h.add(l.distance), h.add(l.min_separation), h.add(l.min_overlap);
  h.add(l.overlap_distance), h.add(l.max_candidates), h.add(l.icp_distance);
  h.add(l.icp_iterations), h.add(l.icp_epsilon), h.add(l.max_drift), h.add(l.distribute_error);
  h.add(l.relax_each_loop), h.add(l.lum_iterations_per_loop), h.add(l.lum_distance);
  h.add(l.lum_final_distance), h.add(l.lum_iterations), h.add(l.lum_epsilon);
  h.add(l.lum_link_iterations), h.add(l.lum_point_to_plane), h.add(l.lum_queries_per_scan);
  h.add(l.sequence_constraints), h.add(l.sequence_cauchy_scale), h.add(l.revisit_rounds);
  h.add(p.median_range);
  h.add(static_cast<std::uint64_t>(num_scans)), h.add(static_cast<std::uint64_t>(segment_size));
  h.add(static_cast<std::uint64_t>(overlap));
  return h.value;
}

} // namespace

std::pair<std::size_t, std::size_t>
scansOfRank(std::size_t num_scans, std::size_t segment_size, int rank, int size)
{
  const auto segments = slam::splitSequence(num_scans, segment_size, 1); // own scans only
  const auto [begin, end] = linkRange(segments.size(), rank, size);
  if (begin == end)
    return {0, 0};
  return {segments[begin].begin, segments[end - 1].end};
}

RankExchange::RankExchange(MPI_Comm comm, std::function<int(std::size_t)> owner)
    : comm_(comm)
    , owner_(std::move(owner))
{
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
}

void
RankExchange::broadcast(int root, std::vector<double>& values)
{
  std::uint64_t n = values.size();
  MPI_Bcast(&n, 1, MPI_UINT64_T, root, comm_);
  values.resize(n);
  MPI_Bcast(values.data(), static_cast<int>(n), MPI_DOUBLE, root, comm_);
  if (rank_ == root)
    bytes_sent_ += (n + 1) * sizeof(double) * static_cast<std::uint64_t>(size_ - 1);
}

void
RankExchange::maximum(std::vector<double>& values)
{
  MPI_Allreduce(
      MPI_IN_PLACE, values.data(), static_cast<int>(values.size()), MPI_DOUBLE, MPI_MAX, comm_);
  if (size_ > 1)
    bytes_sent_ += values.size() * sizeof(double);
}

void
RankExchange::send(int from, int to, slam::KeptScan& scan)
{
  constexpr int kTag = 12;
  if (rank_ == from) {
    Writer w;
    writePoints(w, *scan.points, scan.normals);
    std::uint64_t n = w.bytes().size();
    MPI_Send(&n, 1, MPI_UINT64_T, to, kTag, comm_);
    MPI_Send(w.bytes().data(), static_cast<int>(n), MPI_BYTE, to, kTag, comm_);
    bytes_sent_ += n;
    ++scans_sent_;
  }
  else if (rank_ == to) {
    std::uint64_t n = 0;
    MPI_Recv(&n, 1, MPI_UINT64_T, from, kTag, comm_, MPI_STATUS_IGNORE);
    std::vector<char> bytes(n);
    MPI_Recv(bytes.data(), static_cast<int>(n), MPI_BYTE, from, kTag, comm_, MPI_STATUS_IGNORE);
    Reader in(bytes);
    scan.points = readPoints(in, scan.normals);
  }
}

void
RankExchange::relax(ParallelLUM<slam::PointT>& lum)
{
  DistributedLUM<slam::PointT>::computeOn(
      lum, comm_, reasons_, [this](std::size_t source, std::size_t) { return owner_(source); });
}

namespace {

/** The segments and the automatic lengths' median range (from scan 0 on rank 0),
 *  agreed by all ranks. */
std::pair<std::vector<slam::Segment>, double>
startSegments(MPI_Comm comm,
              int rank,
              std::size_t num_scans,
              std::size_t segment_size,
              std::size_t overlap,
              slam::ScanSource& read,
              const slam::Parameters& params)
{
  std::string error;
  std::vector<slam::Segment> segments;
  double range = 0.0;
  try {
    segments = slam::splitSequence(num_scans, segment_size, overlap);
    if (num_scans == 0)
      throw std::invalid_argument("no scans");
    if (rank == 0) // its first segment starts with scan 0
      range = slam::sequenceMedianRange(read, params);
  }
  catch (const std::exception& e) {
    error = e.what();
  }
  throwIfAnyFailed(comm, error);
  MPI_Bcast(&range, 1, MPI_DOUBLE, 0, comm);
  return {segments, range};
}

/** This rank's block of segments [begin, end) through their front ends; errors agreed
 *  by all ranks. */
std::vector<std::vector<slam::ScanRecord>>
matchOwnSegments(MPI_Comm comm,
                 const std::vector<slam::Segment>& segments,
                 std::size_t begin,
                 std::size_t end,
                 const slam::Parameters& params,
                 double range,
                 const slam::ScanSource& read,
                 const slam::SegmentProgress& progress,
                 slam::StageTimes& times,
                 SegmentsReport& out)
{
  const pcl::StopWatch start;
  std::size_t total = 0, done = 0;
  for (std::size_t s = begin; s < end; ++s)
    total += segments[s].end - segments[s].first;
  std::vector<std::vector<slam::ScanRecord>> mine;
  std::string error;
  try {
    for (std::size_t s = begin; s < end; ++s) {
      auto step = [&](std::size_t k) {
        if (progress)
          progress("match", done + k, total);
      };
      mine.push_back(slam::matchSegment(segments[s], params, range, read, step, &times));
      done += segments[s].end - segments[s].first;
      out.own_scans += segments[s].end - segments[s].begin;
    }
  }
  catch (const std::exception& e) {
    error = e.what();
  }
  out.front_end_seconds = start.getTimeSeconds();
  const pcl::StopWatch wait;
  throwIfAnyFailed(comm, error);
  out.wait_seconds = wait.getTimeSeconds();
  return mine;
}

/** Segment s's matched scans on every rank: the owner's own, broadcast to the others
 *  (without their points). Adds the bytes this rank sent to `sent`. */
std::vector<slam::ScanRecord>
shareSegment(MPI_Comm comm,
             int owner,
             int rank,
             int size,
             std::vector<slam::ScanRecord>* own,
             std::uint64_t& sent)
{
  std::vector<slam::ScanRecord> scans;
  if (owner == rank) {
    scans = std::move(*own);
    if (size > 1) {
      Writer w;
      w.put<std::uint64_t>(scans.size());
      for (const auto& m : scans)
        writeMatched(w, m);
      broadcastBytes(comm, owner, w.bytes());
      sent += w.bytes().size() * static_cast<std::size_t>(size - 1);
    }
    return scans;
  }
  std::vector<char> bytes;
  broadcastBytes(comm, owner, bytes);
  Reader in(bytes);
  scans.resize(in.get<std::uint64_t>());
  for (auto& m : scans)
    m = readMatched(in);
  return scans;
}

/** Which rank keeps scan i: the rank whose own scans hold it. */
std::function<int(std::size_t)>
scanOwner(std::size_t num_scans, std::size_t segment_size, int size)
{
  std::vector<std::size_t> ends; // of the own scans of ranks 0, 1, ... that have any
  for (int r = 0; r < size; ++r) {
    const auto [b, e] = scansOfRank(num_scans, segment_size, r, size);
    if (b < e)
      ends.push_back(e);
  }
  return [ends](std::size_t i) {
    return static_cast<int>(std::upper_bound(ends.begin(), ends.end(), i) - ends.begin());
  };
}

} // namespace

std::unique_ptr<slam::Pipeline>
mapSegments(MPI_Comm comm,
            const slam::Parameters& params,
            std::size_t num_scans,
            std::size_t segment_size,
            std::size_t overlap,
            const slam::ScanSource& source,
            SegmentsReport* report,
            const slam::SegmentProgress& progress)
{
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  SegmentsReport local;
  SegmentsReport& out = report ? *report : local;
  out = SegmentsReport();
  // Same inputs everywhere, else the ranks would map different sequences.
  requireSameOnAllRanks(comm,
                        inputHash(params, num_scans, segment_size, overlap),
                        "mpi::mapSegments: the options or the number of scans");
  slam::ScanSource read = source;
  const auto [segments, range] =
      startSegments(comm, rank, num_scans, segment_size, overlap, read, params);
  const auto [own_begin, own_end] = linkRange(segments.size(), rank, size);
  slam::StageTimes times;
  std::vector<std::vector<slam::ScanRecord>> mine = matchOwnSegments(
      comm, segments, own_begin, own_end, params, range, read, progress, times, out);
  out.segments = segments.size();
  out.own_segments = own_end - own_begin;

  // Loop closing over the whole sequence, the same graph on every rank: each segment's
  // matched scans (steps, information, reports) from the rank that owns it, in order;
  // their points stay there (RankExchange).
  const auto exchange =
      std::make_shared<RankExchange>(comm, scanOwner(num_scans, segment_size, size));
  std::unique_ptr<slam::Pipeline> pipeline(new slam::Pipeline(params, range));
  pipeline->setExchange(exchange);
  std::uint64_t sent = 0; // by this rank
  for (int owner = 0; owner < size; ++owner) {
    const auto [begin, end] = linkRange(segments.size(), owner, size);
    for (std::size_t s = begin; s < end; ++s)
      for (slam::ScanRecord& m : shareSegment(
               comm, owner, rank, size, owner == rank ? &mine[s - begin] : nullptr, sent)) {
        pipeline->addMatched(std::move(m));
        if (progress)
          progress("join", pipeline->size(), num_scans);
      }
  }
  pipeline->addTimes(times);
  // finish() relaxes once more: the report's bytes come from the exchange, which the
  // pipeline keeps; counted here up to the joins.
  sent += exchange->bytesSent();
  std::uint64_t counts[2] = {sent, exchange->scansSent()}, all[2] = {0, 0};
  MPI_Allreduce(counts, all, 2, MPI_UINT64_T, MPI_SUM, comm);
  out.bytes_shared = all[0];
  out.scans_sent = all[1];
  out.kept_scans = pipeline->keptScans();
  std::size_t remote_links = 0; // measured off rank 0: their blocks travel
  for (const slam::Link& l : pipeline->links())
    remote_links += exchange->owner(l.source) != 0 ? 1 : 0;
  out.lum_bytes_per_iteration =
      DistributedLUM<slam::PointT>::iterationBytes(remote_links, num_scans, size);
  return pipeline;
}

} // namespace mpi
} // namespace pcl_parallel
