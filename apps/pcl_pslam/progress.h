/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * pcl_pslam's progress on stderr (a live line with ETA on a terminal, else a line per
 * stage), the time of every stage and step, and SIGINT/SIGTERM/SIGHUP: before the outputs
 * the run ends at once, its temporary directories removed; while they are written a signal
 * only sets a flag that the next progress update throws as Interrupted, and the output
 * directory's destructor removes them.
 */
#pragma once

#include <pcl_parallel/io/atomic_write.h>
#include <pcl_parallel/io/stderr_capture.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

namespace pcl_pslam {

/** A signal: io::writeAtomically passes a WriteAborted on unchanged, so the message stays
 *  the signal's, not the file's. */
struct Interrupted : pcl_parallel::io::WriteAborted {
  explicit Interrupted(int signal);
  int signal; ///< SIGINT or SIGTERM; exit status 128 + signal
};

/** Routes SIGINT and SIGTERM to checkInterrupt()'s flag; `quiet`: without the message (MPI
 *  ranks but 0); `ranks`: the job's size (the SIGTERM message then names mpirun). */
void
installSignalHandlers(bool quiet = false, int ranks = 1);

/** While true, a signal stops the run at the next progress update instead of at once. */
void
setWritingOutputs(bool writing);

/** Throws Interrupted once a signal arrived. */
void
checkInterrupt();

class ProgressReporter {
public:
  using Clock = std::chrono::steady_clock;

  /** quiet: print nothing; live: one updating line with ETA (stderr is a terminal).
   *  capture: what PCL and the library print on stderr is collected and shown at the end of
   *  each stage, condensed (io::StderrCapture). */
  ProgressReporter(bool quiet, bool live, bool capture = false);
  ~ProgressReporter();
  ProgressReporter(const ProgressReporter&) = delete;
  ProgressReporter&
  operator=(const ProgressReporter&) = delete;

  /** `done` of `total` steps of `stage` are done; a new name ends the previous stage (its
   *  clock started at the previous update). Checks for a signal first. The environment's
   *  PCL_PSLAM_TEST_SIGNAL_AT=STAGE[:SIG] (a test hook) raises SIGINT (or TERM, HUP, KILL)
   *  at the stage's first update. */
  void
  update(const std::string& stage, std::size_t done, std::size_t total);

  /** Ends the current stage (prints its line). */
  void
  finish();

  struct Stage {
    std::string name;
    double seconds = 0.0;
    std::size_t steps = 0;
  };
  const std::vector<Stage>&
  stages() const
  {
    return stages_;
  }
  /** Seconds since construction. */
  double
  elapsed() const;

  /** A line for the user (on the real stderr), unless quiet. */
  void
  note(const std::string& text);

private:
  /** Prints the captured messages so far, condensed. */
  void
  drainWarnings();

  bool quiet_, live_;
  std::unique_ptr<pcl_parallel::io::StderrCapture> capture_;
  std::FILE* out_ = stderr; ///< where progress goes (the real stderr)
  Clock::time_point start_, stage_start_, last_;
  bool open_ = false;
  std::size_t total_ = 0;
  std::vector<Stage> stages_;
  std::string signal_stage_; ///< PCL_PSLAM_TEST_SIGNAL_AT's stage
  int signal_ = 0;           ///< and its signal
};

} // namespace pcl_pslam
