/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "progress.h"

#include <csignal>
#include <cstdio>

namespace pcl_pslam {

namespace {

volatile std::sig_atomic_t g_signal = 0;

extern "C" void
onSignal(int s)
{
  g_signal = s;
}

} // namespace

Interrupted::Interrupted(int s)
    : std::runtime_error(s == SIGTERM ? "terminated (SIGTERM)" : "interrupted (SIGINT)")
    , signal(s)
{}

void
installSignalHandlers()
{
  std::signal(SIGINT, onSignal);
  std::signal(SIGTERM, onSignal);
}

void
checkInterrupt()
{
  if (g_signal != 0)
    throw Interrupted(g_signal);
}

ProgressReporter::ProgressReporter(bool quiet, bool live)
    : quiet_(quiet), live_(live), start_(Clock::now()), stage_start_(start_), last_(start_)
{}

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
    stages_.push_back(Stage{stage, 0.0, 0, {}});
    stage_start_ = last_; // the stage began when the one before it last reported
    open_ = true;
  }
  Stage& s = stages_.back();
  if (done > 0) // done = 0 only opens the stage
    s.step_seconds.push_back(std::chrono::duration<double>(now - last_).count());
  s.steps = done;
  s.seconds = std::chrono::duration<double>(now - stage_start_).count();
  total_ = total;
  last_ = now;
  if (quiet_ || !live_)
    return;
  const double eta = done > 0 && total > done ? s.seconds / done * (total - done) : 0.0;
  std::fprintf(stderr, "\r\033[K%-7s %5d / %-5d %7.1f s", stage.c_str(), done, total, s.seconds);
  if (eta > 0.0)
    std::fprintf(stderr, "   ETA %.0f s", eta);
  std::fflush(stderr);
}

void
ProgressReporter::finish()
{
  if (!open_)
    return;
  open_ = false;
  const Stage& s = stages_.back();
  if (quiet_)
    return;
  if (live_)
    std::fprintf(stderr, "\r\033[K");
  std::fprintf(stderr, "%-7s %5d / %-5d %7.1f s\n", s.name.c_str(), s.steps, total_, s.seconds);
  std::fflush(stderr);
}

} // namespace pcl_pslam
