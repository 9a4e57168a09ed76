/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "progress.h"

#include <pcl_parallel/io/output_directory.h>

#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <unistd.h>
#include <utility>

namespace pcl_pslam {

namespace {

volatile std::sig_atomic_t g_signal = 0;
volatile std::sig_atomic_t g_writing = 0;   // 1 while outputs are being written
volatile std::sig_atomic_t g_quiet = 0;     // 1: no message (not MPI rank 0)
volatile std::sig_atomic_t g_ranks = 1;     // MPI ranks of the job
volatile std::sig_atomic_t g_stderr_fd = 2; // the real stderr while PCL's is captured
// Set by the first handler that ends the run: a signal may come twice (timeout, a ^C to the
// process group), each on another thread, and only one may write the message.
std::atomic<int> g_ending{0};
static_assert(std::atomic<int>::is_always_lock_free, "signal handlers need a lock-free flag");

/** What ended the run, as the messages name it. */
const char*
signalName(int s)
{
  return s == SIGTERM  ? "terminated (SIGTERM)"
         : s == SIGHUP ? "hung up (SIGHUP)"
                       : "interrupted (SIGINT)";
}

/** Before the outputs nothing can be left half-written and a match can take seconds: the
 *  run ends at once (write, the temporaries' removal, _exit: async-signal-safe). While
 *  writing, the flag. */
extern "C" void
onSignal(int s)
{
  g_signal = s;
  if (g_writing || g_ending.exchange(1) != 0)
    return; // the other handler exits for both
  // One message from the signal's name, assembled without allocating (async-signal-safe)
  // and written at once, so a progress line cannot split it.
  const char* parts[] = {"pcl_pslam: ",
                         signalName(s),
                         s == SIGTERM && g_ranks > 1
                             ? " by mpirun: a rank died (mpirun's message names it) or the "
                               "job was stopped"
                             : "",
                         "; no outputs were written\n"};
  char msg[256];
  std::size_t n = 0;
  for (const char* part : parts)
    for (; *part && n < sizeof msg; ++part)
      msg[n++] = *part;
  if (!g_quiet && ::write(g_stderr_fd, msg, n) < 0) { /* nothing left to tell */
  }
  pcl_parallel::io::removeTemporariesNow(); // the outputs' and the demo's
  ::_exit(128 + s);
}

} // namespace

Interrupted::Interrupted(int s)
    : pcl_parallel::io::WriteAborted(signalName(s))
    , signal(s)
{}

void
installSignalHandlers(bool quiet, int ranks)
{
  g_quiet = quiet ? 1 : 0;
  g_ranks = ranks;
  for (const int s : {SIGINT, SIGTERM, SIGHUP}) // a closed terminal ends the run as ^C does
    std::signal(s, onSignal);
}

void
setWritingOutputs(bool writing)
{
  g_writing = writing ? 1 : 0;
}

void
checkInterrupt()
{
  if (g_signal != 0)
    throw Interrupted(g_signal);
}

ProgressReporter::ProgressReporter(bool quiet, bool live, bool capture)
    : quiet_(quiet)
    , live_(live)
    , start_(Clock::now())
    , stage_start_(start_)
    , last_(start_)
{
  if (const char* at = std::getenv("PCL_PSLAM_TEST_SIGNAL_AT"); at && *at) {
    const std::string hook = at;
    const std::size_t colon = hook.find(':');
    signal_stage_ = hook.substr(0, colon);
    const std::string name = colon == std::string::npos ? "INT" : hook.substr(colon + 1);
    signal_ = name == "TERM"   ? SIGTERM
              : name == "HUP"  ? SIGHUP
              : name == "KILL" ? SIGKILL // a killed run's temporaries
                               : SIGINT;
  }
  if (!capture)
    return;
  capture_ = std::make_unique<pcl_parallel::io::StderrCapture>();
  out_ = capture_->terminal();
  g_stderr_fd = capture_->terminalDescriptor();
}

ProgressReporter::~ProgressReporter()
{
  if (!capture_)
    return;
  drainWarnings();
  g_stderr_fd = 2; // before the capture ends
}

void
ProgressReporter::drainWarnings()
{
  if (!capture_)
    return;
  for (const std::string& line : capture_->take())
    std::fprintf(out_, "%s\n", line.c_str());
  std::fflush(out_);
}

double
ProgressReporter::elapsed() const
{
  return std::chrono::duration<double>(Clock::now() - start_).count();
}

void
ProgressReporter::update(const std::string& stage, std::size_t done, std::size_t total)
{
  if (signal_ != 0 && stage == signal_stage_)
    std::raise(std::exchange(signal_, 0)); // the test hook, once
  checkInterrupt();
  const auto now = Clock::now();
  if (!open_ || stages_.back().name != stage) {
    finish();
    stages_.push_back(Stage{stage, 0.0, 0});
    stage_start_ = last_; // the stage began when the one before it last reported
    open_ = true;
  }
  Stage& s = stages_.back();
  s.steps = done;
  s.seconds = std::chrono::duration<double>(now - stage_start_).count();
  total_ = total;
  last_ = now;
  if (quiet_ || !live_)
    return;
  const double eta =
      done > 0 && total > done ? s.seconds / static_cast<double>(done) * (total - done) : 0.0;
  std::fprintf(
      out_, "\r\033[K%-7s %5zu / %-5zu %7.1f s", stage.c_str(), done, total, s.seconds);
  if (eta > 0.0)
    std::fprintf(out_, "   ETA %.0f s", eta);
  std::fflush(out_);
}

void
ProgressReporter::note(const std::string& text)
{
  if (quiet_)
    return;
  if (live_ && open_)
    std::fprintf(out_, "\r\033[K");
  std::fprintf(out_, "%s\n", text.c_str());
  std::fflush(out_);
}

void
ProgressReporter::finish()
{
  if (!open_)
    return;
  open_ = false;
  const Stage& s = stages_.back();
  if (live_ && !quiet_)
    std::fprintf(out_, "\r\033[K");
  drainWarnings(); // shown even with -q
  if (quiet_)
    return;
  std::fprintf(out_, "%-7s %5zu / %-5zu %7.1f s\n", s.name.c_str(), s.steps, total_, s.seconds);
  std::fflush(out_);
}

} // namespace pcl_pslam
