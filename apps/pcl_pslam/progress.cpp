/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "progress.h"

#include <atomic>
#include <cctype>
#include <csignal>
#include <cstdio>
#include <map>
#include <unistd.h>

namespace pcl_pslam {

namespace {

volatile std::sig_atomic_t g_signal = 0;
volatile std::sig_atomic_t g_writing = 0;   // 1 while outputs are being written
volatile std::sig_atomic_t g_quiet = 0;     // 1: no message (not MPI rank 0)
volatile std::sig_atomic_t g_ranks = 1;     // MPI ranks of the job
volatile std::sig_atomic_t g_stderr_fd = 2; // the real stderr while PCL's is captured
char g_remove_dir[4096] = {0};              // an --out this run created, removed if empty
// Set by the first handler that ends the run: a signal may come twice (timeout, a ^C to the
// process group), each on another thread, and only one may write the message.
std::atomic<int> g_ending{0};
static_assert(std::atomic<int>::is_always_lock_free, "signal handlers need a lock-free flag");

/** Before the outputs nothing can be left half-written and a match can take seconds: the
 *  run ends at once (write, rmdir, _exit: async-signal-safe). While writing, the flag. */
extern "C" void
onSignal(int s)
{
  g_signal = s;
  if (g_writing || g_ending.exchange(1) != 0)
    return; // the other handler exits for both
  const char* msg = s != SIGTERM ? "pcl_pslam: interrupted (SIGINT); no outputs were written\n"
                    : g_ranks > 1
                        ? "pcl_pslam: terminated (SIGTERM) by mpirun: a rank died (mpirun's "
                          "message names it) or the job was stopped; no outputs were written\n"
                        : "pcl_pslam: terminated (SIGTERM); no outputs were written\n";
  std::size_t n = 0;
  while (msg[n])
    ++n;
  if (!g_quiet && ::write(g_stderr_fd, msg, n) < 0) { /* nothing left to tell */
  }
  if (g_remove_dir[0])
    ::rmdir(g_remove_dir); // fails, harmlessly, unless empty
  ::_exit(128 + s);
}

} // namespace

Interrupted::Interrupted(int s)
    : pcl_parallel::io::WriteAborted(s == SIGTERM ? "terminated (SIGTERM)"
                                                  : "interrupted (SIGINT)")
    , signal(s)
{}

void
installSignalHandlers(bool quiet, int ranks)
{
  g_quiet = quiet ? 1 : 0;
  g_ranks = ranks;
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
}

void
setWritingOutputs(bool writing)
{
  g_writing = writing ? 1 : 0;
}

void
removeIfEmptyOnSignal(const std::string& dir)
{
  if (dir.size() < sizeof g_remove_dir)
    dir.copy(g_remove_dir, dir.size()), g_remove_dir[dir.size()] = '\0';
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
  if (!capture)
    return;
  std::fflush(stderr);
  capture_ = std::tmpfile();
  saved_stderr_ = capture_ ? ::dup(2) : -1;
  std::FILE* out = saved_stderr_ >= 0 ? ::fdopen(::dup(saved_stderr_), "w") : nullptr;
  if (!out || ::dup2(::fileno(capture_), 2) < 0) { // no capture: print as PCL does
    if (out)
      std::fclose(out);
    if (saved_stderr_ >= 0)
      ::close(saved_stderr_), saved_stderr_ = -1;
    if (capture_)
      std::fclose(capture_), capture_ = nullptr;
    return;
  }
  out_ = out;
  g_stderr_fd = saved_stderr_;
}

ProgressReporter::~ProgressReporter()
{
  if (!capture_)
    return;
  drainWarnings();
  std::fflush(stderr);
  g_stderr_fd = 2;
  ::dup2(saved_stderr_, 2);
  ::close(saved_stderr_);
  std::fclose(out_);
  std::fclose(capture_);
}

void
ProgressReporter::drainWarnings()
{
  if (!capture_)
    return;
  std::fflush(stderr);
  std::fseek(capture_, read_, SEEK_SET);
  // Group by the message with its numbers blanked: "Link 3 -> 9 dropped" and "Link 4 ->
  // 12 dropped" are one kind.
  std::map<std::string, std::pair<int, std::string>> kinds;
  std::vector<std::string> order;
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, capture_)) {
    std::string line(buffer);
    while (!line.empty() && (line.back() == '\n' || line.back() == '\r'))
      line.pop_back();
    if (line.empty())
      continue;
    std::string key;
    for (char c : line)
      if (!std::isdigit(static_cast<unsigned char>(c)))
        key += c;
      else if (key.empty() || key.back() != '#')
        key += '#';
    auto& k = kinds[key];
    if (k.first++ == 0)
      k.second = line, order.push_back(key);
  }
  read_ = std::ftell(capture_);
  std::fseek(capture_, 0, SEEK_END);
  for (const auto& key : order) {
    const auto& [count, first] = kinds[key];
    if (count == 1)
      std::fprintf(out_, "%s\n", first.c_str());
    else
      std::fprintf(out_, "%s  (and %d more like it)\n", first.c_str(), count - 1);
  }
  std::fflush(out_);
}

double
ProgressReporter::elapsed() const
{
  return std::chrono::duration<double>(Clock::now() - start_).count();
}

void
ProgressReporter::update(const std::string& stage, int done, int total)
{
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
  const double eta = done > 0 && total > done ? s.seconds / done * (total - done) : 0.0;
  std::fprintf(out_, "\r\033[K%-7s %5d / %-5d %7.1f s", stage.c_str(), done, total, s.seconds);
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
  std::fprintf(out_, "%-7s %5d / %-5d %7.1f s\n", s.name.c_str(), s.steps, total_, s.seconds);
  std::fflush(out_);
}

} // namespace pcl_pslam
