/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pcl_pslam: 6D SLAM with pICP and pLUM (the paper's pipeline) on a directory of scans,
 * or on the built-in simulated scan set (`pcl_pslam demo`): parse, load, run, write.
 * Exit status: 0 done, 1 bad data, 2 bad usage, 128 + signal when interrupted.
 */
#include "evaluate_command.h"
#include "input.h"
#include "options.h"
#include "outputs.h"
#include "progress.h"
#include "simulate_command.h"
#include "slam_pipeline.h"

#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/mpi/session.h>
#include <pcl_parallel/slam/preprocess.h>

#include <pcl/console/print.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <memory>
#include <unistd.h>
#include <utility>
#include <vector>
#if defined(__GLIBC__)
#include <malloc.h> // mallopt
#endif

namespace {

namespace fs = std::filesystem;

/** Removes a directory tree when it goes out of scope (the demo's temporary scans). */
struct RemoveDirectory {
  std::string dir;
  ~RemoveDirectory()
  {
    std::error_code ec;
    if (!dir.empty())
      fs::remove_all(dir, ec);
  }
};

/** A failed run leaves no empty --out behind that it created itself. */
void
removeIfEmpty(bool created, const std::string& dir)
{
  std::error_code ec;
  if (created && std::filesystem::is_empty(dir, ec))
    std::filesystem::remove(dir, ec);
}

using Session = pcl_parallel::mpi::Session;

/** Ends a failed run with `status`; rank 0 prints `message`. A failure of all ranks
 *  together (Session::collective) ends them in step, rank 0's status on all, after rank 0
 *  has spoken (the launcher ends the job at the first non-zero exit); a failure of this
 *  rank alone returns at once (the launcher ends the others). */
int
fail(const Session& ranks, int status, const std::string& message, const std::exception& error)
{
  if (ranks.size() > 1) { // the run is over: the launcher's SIGTERM to the others adds nothing
    std::signal(SIGINT, SIG_IGN);
    std::signal(SIGTERM, SIG_IGN);
  }
  if (ranks.rank() == 0)
    std::fprintf(stderr, "pcl_pslam: %s\n", message.c_str());
  if (ranks.size() > 1 && ranks.collective(error)) {
    std::fflush(stderr);
    status = ranks.broadcast(status);
  }
  return status;
}

/** `demo`'s simulated scans or `run`'s directory, opened (no scan read yet), with the
 *  notes and warnings about it. The demo's scans go with `cleanup` unless --keep. */
pcl_pslam::Input
openInput(pcl_pslam::Options& o,
          const Session& ranks,
          pcl_pslam::ProgressReporter& progress,
          RemoveDirectory& cleanup)
{
  pcl_parallel::slam::Poses truth;
  std::string demo_dir;
  if (o.command == "demo") { // a preset, written and read back as `run` reads a directory
    progress.update("simulate", 0, 1);
    ranks.agree([&] { demo_dir = pcl_pslam::simulateDemo(o); }); // each rank its own copy
    progress.update("simulate", 1, 1);
    truth = pcl_parallel::io::loadKittiPoses(demo_dir + "/ground_truth.txt");
  }
  else if (std::error_code ec; o.poses_file.empty() && !o.no_poses &&
                               fs::exists(fs::path(o.dir) / "odometry.txt", ec)) {
    o.poses_file = (fs::path(o.dir) / "odometry.txt").string(); // as `simulate` writes it
    progress.note("odometry from " + o.poses_file);
  }
  pcl_pslam::Input in;
  ranks.agree([&] { in = pcl_pslam::openDirectory(o); });
  in.truth = truth;
  if (o.keep.empty())
    cleanup.dir = demo_dir; // the temporary scans go when main returns
  progress.note(std::to_string(in.size()) + " scans" +
                (in.odometry        ? ""
                 : o.no_pose_search ? "; no initial poses: constant-velocity guesses"
                                    : "; no initial poses: constant-velocity guesses, "
                                      "poses searched where a match looks wrong"));
  if (const std::string w = pcl_pslam::keyframeWarning(in, o.deskew, o.sweep_period);
      !w.empty() && ranks.rank() == 0)
    std::fprintf(stderr, "pcl_pslam: warning: %s\n", w.c_str());
  return in;
}

/** The pipeline's parameters for the options and the input. */
pcl_parallel::slam::Parameters
runParameters(const pcl_pslam::Options& o, const pcl_pslam::Input& in)
{
  pcl_parallel::slam::Parameters params = pcl_pslam::toParameters(o, in.scale);
  params.guess.up = Eigen::Vector3d::Unit(in.up);
  if (!in.has_stamps && params.deskew.sweep_period > 0.0)
    throw pcl_pslam::UsageError("--sweep-period needs the scans' time stamps: no --times "
                                "and no times.txt in " +
                                o.dir + " or its parent");
  return params;
}

/** Reads scan k of `in` when the pipeline takes it. Per-point times only matter to
 *  deskewing: read then (without it, the first scan's, to tell the user they are
 *  there). Segments read their overlap scans again: each scan is counted once. */
pcl_pslam::ScanReader
scanReader(pcl_pslam::Input& in, bool deskew)
{
  auto timed = std::make_shared<std::vector<bool>>(in.size(), false);
  auto looked = std::make_shared<bool>(false);
  return [&in, deskew, timed, looked](std::size_t k) {
    const auto start = std::chrono::steady_clock::now();
    pcl_parallel::slam::SourceScan scan;
    const bool times = deskew || !*looked;
    *looked = true;
    scan.cloud = pcl_parallel::io::readScan(in, k, times ? &scan.point_times : nullptr);
    if (!(*timed)[k] && pcl_parallel::slam::spansSweep(scan.point_times)) {
      (*timed)[k] = true;
      ++in.timed_scans;
    }
    if (!deskew)
      scan.point_times.clear();
    in.read_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return scan;
  };
}

/** `run` and `demo` once the output directory is ready: map the input, write the
 *  outputs, print the summary. */
void
mapAndWrite(pcl_pslam::Options& o,
            const Session& ranks,
            pcl_pslam::ProgressReporter& progress,
            const std::string& command_line)
{
  RemoveDirectory cleanup;
  pcl_pslam::Input in = openInput(o, ranks, progress, cleanup);
  const pcl_parallel::slam::Parameters params = runParameters(o, in);
  // Streamed: each scan is read when the pipeline takes it, and dropped after.
  const pcl_pslam::Result r =
      pcl_pslam::run(scanReader(in, params.deskew.enabled),
                     in.size(),
                     in.odometry ? in.initial : pcl_pslam::Poses(),
                     in.has_stamps ? in.stamps : std::vector<double>(),
                     params,
                     pcl_pslam::toMappingOptions(o, ranks.size()),
                     [&](const std::string& stage, int done, int total) {
                       progress.update(stage, done, total);
                     });
  progress.finish();
  std::size_t points = 0; // every scan's, wherever it was read
  for (const auto& report : r.reports)
    points += report.points;
  const std::string read_time = std::to_string(in.read_seconds).substr(0, 4) + " s";
  if (r.spread.ranks == 1)
    if (const std::string note = pcl_pslam::deskewNote(in, params.deskew.enabled);
        !note.empty())
      progress.note(note);
  progress.note(std::to_string(points) + " points read" +
                (r.spread.ranks > 1 ? " by " + std::to_string(r.spread.ranks) +
                                          " ranks (rank 0's in " + read_time + ")"
                                    : " in " + read_time));
  pcl_pslam::setWritingOutputs(true);
  if (r.spread.ranks > 1) { // every rank its part of the map, then rank 0 the rest
    ranks.agree([&] { pcl_pslam::writeMapTile(o, in, r, progress); });
    if (ranks.rank() != 0)
      return;
  }
  const auto written = pcl_pslam::writeOutputs(o, in, r, progress, command_line);
  pcl_pslam::printSummary(o, in, r, written, progress.elapsed());
}

/** `run` and `demo`: exit status 0 done, 1 bad data, 2 bad usage, 128 + signal. */
int
runMapping(pcl_pslam::Options& o, const Session& ranks, const std::string& command_line)
{
  const bool quiet_rank = ranks.rank() != 0; // rank 0 speaks for all
  // PCL's own warnings stay visible (e.g. a reader's complaint), on stderr.
  pcl::console::setVerbosityLevel(pcl::console::L_WARN);
  pcl_pslam::installSignalHandlers(quiet_rank, ranks.size());
  bool created_out = false;
  try {
    ranks.agree([&] { // before any work; by rank 0, for all
      if (ranks.rank() == 0)
        created_out = pcl_pslam::prepareOutputDirectory(o.out);
    });
    if (created_out)
      pcl_pslam::removeIfEmptyOnSignal(o.out);
    pcl_pslam::ProgressReporter progress(o.quiet || quiet_rank, ::isatty(2) != 0, true);
    mapAndWrite(o, ranks, progress, command_line);
  }
  catch (const pcl_pslam::Interrupted& e) {
    removeIfEmpty(created_out, o.out);
    return fail(
        ranks, 128 + e.signal, std::string(e.what()) + "; outputs are complete or absent", e);
  }
  catch (const pcl_pslam::UsageError& e) {
    removeIfEmpty(created_out, o.out);
    return fail(ranks, 2, e.what(), e);
  }
  catch (const std::exception& e) { // DataError and the pipeline's own checks
    removeIfEmpty(created_out, o.out);
    return fail(ranks, 1, e.what(), e);
  }
  return 0;
}

} // namespace

int
runCommand(int argc, char** argv, const Session& ranks)
{
  pcl_pslam::Options o;
  try {
    ranks.agree([&] { o = pcl_pslam::parseCommandLine(argc, argv); });
  }
  catch (const std::exception& e) { // a usage error, here or on another rank
    return fail(ranks, 2, e.what(), e);
  }
  if (o.help) {
    if (ranks.rank() == 0)
      std::fputs(pcl_pslam::helpText(o.command).c_str(), stdout);
    return 0;
  }
  if (o.command == "evaluate" || o.command == "simulate") {
    if (ranks.rank() != 0) // one rank does it (the others would write the same files)
      return 0;
    return o.command == "evaluate" ? pcl_pslam::evaluateCommand(o.rest, std::cout, std::cerr)
                                   : pcl_pslam::simulateCommand(o.rest, std::cout, std::cerr);
  }
  std::string command_line;
  for (int i = 0; i < argc; ++i)
    command_line += (i ? " " : "") + std::string(argv[i]);
  return runMapping(o, ranks, command_line);
}

/** Each scan allocates and frees buffers of a few MB (its points, voxel keys, trees).
 *  glibc's default returns them to the kernel and faults them in again for the next scan,
 *  on the thread that first touches them (docs/design.md, "Serial work per scan"). Kept below
 * 32 MiB (glibc's own cap for its sliding mmap threshold) and up to 128 MiB free at the heap
 * top, they are reused. */
void
keepScanBuffers()
{
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 128 << 20);
#endif
}

/** Standard output that could not be written (a full disk, /dev/full) is a failure:
 *  `evaluate`'s table or JSON is the product, and a run's summary must not vanish. */
int
main(int argc, char** argv)
{
  keepScanBuffers();
  const Session ranks(argc, argv); // MPI, when started by a launcher
  const int status = runCommand(argc, argv, ranks);
  std::cout.flush();
  errno = 0;
  if (std::fflush(stdout) != 0 || std::ferror(stdout) || !std::cout) {
    std::fprintf(stderr,
                 "pcl_pslam: standard output: write error%s%s\n",
                 errno ? ": " : "",
                 errno ? std::strerror(errno) : "");
    return status == 0 ? 1 : status;
  }
  return status;
}
