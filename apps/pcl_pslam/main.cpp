/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pcl_pslam: 6D SLAM with pICP and pLUM (the paper's pipeline) on a directory of scans,
 * or on a simulated preset (`pcl_pslam demo`): parse, open, map, write.
 * Exit status: 0 done, 1 bad data, 2 bad usage, 128 + signal when interrupted.
 */
#include "evaluate_command.h"
#include "input.h"
#include "options.h"
#include "outputs.h"
#include "progress.h"
#include "simulate_command.h"

#include <pcl_parallel/io/output_directory.h>
#include <pcl_parallel/io/scan_io.h>
#include <pcl_parallel/mpi/session.h>
#include <pcl_parallel/slam/findings.h>

#include <pcl/console/print.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <memory>
#include <unistd.h>
#if defined(__GLIBC__)
#include <malloc.h> // mallopt
#endif

namespace pcl_pslam {
namespace {

using Session = pcl_parallel::mpi::Session;
namespace slam = pcl_parallel::slam;

/** Ends a failed run with `status`; rank 0 prints `message`. A failure of all ranks
 *  together (Session::collective) ends them in step with rank 0's status, after rank 0 has
 *  spoken (the launcher ends the job at the first non-zero exit); a failure of this rank
 *  alone returns at once (the launcher ends the others). */
int
fail(const Session& ranks, int status, const std::string& message, const std::exception& error)
{
  if (ranks.size() > 1) { // the run is over: the launcher's SIGTERM to the others adds nothing
    for (const int s : {SIGINT, SIGTERM, SIGHUP})
      std::signal(s, SIG_IGN);
  }
  if (ranks.rank() == 0)
    std::fprintf(stderr, "pcl_pslam: %s\n", message.c_str());
  if (ranks.size() > 1 && ranks.collective(error)) {
    std::fflush(stderr);
    status = ranks.broadcast(status);
  }
  return status;
}

/** `demo`'s simulated scans or `run`'s directory, opened (no scan read yet), with the notes
 *  and warnings about it. The demo's temporary scans live as long as `demo`. */
Input
openInput(Options& o, const Session& ranks, ProgressReporter& progress, DemoScans& demo)
{
  Poses truth;
  if (o.command == "demo") { // a preset, written and read back as `run` reads a directory
    progress.update("simulate", 0, 1);
    ranks.agree([&] { // each rank its own temporary copy; rank 0 the --keep folder
      if (ranks.rank() == 0 || o.keep.empty())
        demo = simulateDemo(o);
    });
    if (!o.keep.empty())
      demo = {ranks.broadcast(demo.dir), ranks.broadcast(demo.moving ? 1 : 0) != 0, {}};
    useDemoScans(o, demo);
    progress.update("simulate", 1, 1);
    truth = pcl_parallel::io::loadKittiPoses(demo.dir + "/ground_truth.txt");
  }
  Input in;
  ranks.agree([&] { in = openDirectory(o); });
  if (o.poses_file.empty() && !in.poses_file.empty()) { // odometry.txt, as `simulate` writes it
    o.poses_file = in.poses_file;
    if (o.command != "demo")
      progress.note("odometry from " + o.poses_file);
  }
  in.truth = truth;
  progress.note(std::to_string(in.size()) + " scans" +
                (in.log_scans ? " of the log's " + std::to_string(in.log_scans) : "") +
                (in.odometry        ? ""
                 : o.no_pose_search ? "; no initial poses: constant-velocity guesses"
                                    : "; no initial poses: constant-velocity guesses, "
                                      "poses searched where a match looks wrong"));
  return in;
}

/** The pipeline's parameters for the options and the input. */
slam::Parameters
runParameters(const Options& o, const Input& in)
{
  slam::Parameters params = toParameters(o, in.scale);
  params.guess.up = Eigen::Vector3d::Unit(in.up);
  if (!in.has_stamps && params.deskew.sweep_period > 0.0)
    throw UsageError("--sweep-period needs the scans' time stamps: no --times and no "
                     "times.txt in " +
                     o.dir + " or its parent");
  return params;
}

/** `run` and `demo` once the output directory is ready: map the input (each scan read when
 *  the pipeline takes it), write the outputs into `out` (rank 0's; the others write their
 *  map tiles into `dir`, its path), swap them in, print the summary. */
void
mapAndWrite(Options& o,
            const Session& ranks,
            ProgressReporter& progress,
            const std::string& command_line,
            pcl_parallel::io::OutputDirectory* out,
            const std::string& dir)
{
  DemoScans demo;
  Input in = openInput(o, ranks, progress, demo);
  const slam::Parameters params = runParameters(o, in);
  if (const std::string w =
          in.has_stamps ? slam::keyframeWarning(in.stamps, params.deskew) : "";
      !w.empty() && ranks.rank() == 0)
    std::fprintf(stderr, "pcl_pslam: warning: %s\n", w.c_str());
  const auto on_progress = [&](const char* stage, std::size_t k, std::size_t n) {
    progress.update(stage, k, n);
  };
  const Result r = slam::mapDirectory(
      in, params, toMappingOptions(o, ranks.size()), on_progress, in.reading);
  progress.finish();
  std::size_t points = 0; // every scan's, wherever it was read
  for (const auto& report : r.reports)
    points += report.points;
  const std::string read_time = std::to_string(in.reading.seconds).substr(0, 4) + " s";
  if (const std::string note =
          slam::deskewNote(in.reading.timed_scans, in.size(), params.deskew.enabled);
      !note.empty() && r.spread.ranks == 1)
    progress.note(note);
  progress.note(std::to_string(points) + " points read" +
                (r.spread.ranks > 1 ? " by " + std::to_string(r.spread.ranks) +
                                          " ranks (rank 0's in " + read_time + ")"
                                    : " in " + read_time));
  setWritingOutputs(true);
  if (r.spread.ranks > 1) { // every rank its part of the map, then rank 0 the rest
    ranks.agree(
        [&] { slam::writeMapTile(dir, in, r, runOutputOptions(o, in, r), on_progress); });
    if (ranks.rank() != 0)
      return;
  }
  const auto written = writeOutputs(o, dir, in, r, progress, command_line);
  out->commit();
  printSummary(o, in, r, written, out->replacesEarlierRun(), progress.elapsed());
}

/** `run` and `demo`: exit status 0 done, 1 bad data, 2 bad usage, 128 + signal. */
int
runMapping(Options& o, const Session& ranks, const std::string& command_line)
{
  const bool quiet_rank = ranks.rank() != 0; // rank 0 speaks for all
  // PCL's own warnings stay visible (e.g. a reader's complaint), on stderr.
  pcl::console::setVerbosityLevel(pcl::console::L_WARN);
  installSignalHandlers(quiet_rank, ranks.size());
  std::unique_ptr<pcl_parallel::io::OutputDirectory> out; // rank 0's
  const auto failed = [&](int status, const std::string& message, const std::exception& e) {
    const std::string text = out ? out->inTarget(message) : message; // names --out's files
    out.reset(); // the outputs so far go: --out as it was
    return fail(ranks, status, text, e);
  };
  try {
    ranks.agree([&] { // before any work; by rank 0, for all
      if (ranks.rank() == 0)
        out = openOutputDirectory(o.out);
    });
    const std::string dir = ranks.broadcast(out ? out->path() : std::string());
    ProgressReporter progress(o.quiet || quiet_rank, ::isatty(2) != 0, true);
    mapAndWrite(o, ranks, progress, command_line, out.get(), dir);
  }
  catch (const Interrupted& e) {
    return failed(128 + e.signal, std::string(e.what()) + "; no outputs were written", e);
  }
  catch (const UsageError& e) {
    return failed(2, e.what(), e);
  }
  catch (const std::exception& e) { // DataError and the pipeline's own checks
    return failed(1, e.what(), e);
  }
  return 0;
}

int
runCommand(int argc, char** argv, const Session& ranks)
{
  Options o;
  try {
    ranks.agree([&] { o = parseCommandLine(argc, argv); });
  }
  catch (const std::exception& e) { // a usage error, here or on another rank
    return fail(ranks, 2, e.what(), e);
  }
  if (o.help) {
    if (ranks.rank() == 0)
      std::fputs(helpText(o.command).c_str(), stdout);
    return 0;
  }
  if (o.command == "evaluate" || o.command == "simulate") {
    if (ranks.rank() != 0) // one rank does it (the others would write the same files)
      return 0;
    return o.command == "evaluate" ? evaluateCommand(o.rest, std::cout, std::cerr)
                                   : simulateCommand(o.rest, std::cout, std::cerr);
  }
  std::string command_line;
  for (int i = 0; i < argc; ++i)
    command_line += (i ? " " : "") + std::string(argv[i]);
  return runMapping(o, ranks, command_line);
}

} // namespace
} // namespace pcl_pslam

/** Standard output that could not be written (a full disk, /dev/full) is a failure:
 *  `evaluate`'s table or JSON is the product, and a run's summary must not vanish. */
int
main(int argc, char** argv)
{
#if defined(__GLIBC__)
  // A scan's buffers of a few MB kept for the next scan instead of returned to the kernel
  // and faulted in again (below glibc's 32 MiB cap for its sliding mmap threshold).
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, 128 << 20);
#endif
  const pcl_parallel::mpi::Session ranks(argc, argv); // MPI, when started by a launcher
  const int status = pcl_pslam::runCommand(argc, argv, ranks);
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
