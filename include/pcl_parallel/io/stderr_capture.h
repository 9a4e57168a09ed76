/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace pcl_parallel {
namespace io {

/** The process's standard error (descriptor 2) redirected into a temporary file while this
 *  lives, so what PCL and the library print there can be shown condensed: PCL's LUM warns
 *  once per link, many times over. Where the redirection fails nothing is captured and
 *  stderr stays as it was. One at a time per process; not thread-safe. */
class StderrCapture {
public:
  StderrCapture();
  /** Restores descriptor 2; what was not taken stays unshown. */
  ~StderrCapture();
  StderrCapture(const StderrCapture&) = delete;
  StderrCapture&
  operator=(const StderrCapture&) = delete;

  /** True while descriptor 2 goes to the capture. */
  bool
  active() const
  {
    return capture_ != nullptr;
  }

  /** The real standard error: a stream of its own while active, else stderr. */
  std::FILE*
  terminal() const
  {
    return terminal_;
  }

  /** The real standard error's descriptor (2 unless active), for a signal handler's write. */
  int
  terminalDescriptor() const
  {
    return saved_;
  }

  /** The lines written to stderr since the last call, one per kind, in order of first
   *  appearance: lines that differ only in their digits ("Link 3 -> 9 dropped", "Link 4
   *  -> 12 dropped") are one kind, shown as the first with "  (and N more like it)".
   *  Empty lines are dropped. */
  std::vector<std::string>
  take();

private:
  std::FILE* capture_ = nullptr;
  std::FILE* terminal_ = stderr;
  int saved_ = 2;
  long read_ = 0; ///< bytes of capture_ already taken
};

} // namespace io
} // namespace pcl_parallel
