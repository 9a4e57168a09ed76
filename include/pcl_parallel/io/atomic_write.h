/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <functional>
#include <ostream>
#include <stdexcept>
#include <string>

/* Every file the library writes (poses, maps, pictures) goes to a temporary name beside
 * its target and is renamed over it (POSIX rename replaces atomically within a file
 * system), so a reader sees the old file or the complete new one, whatever stops the
 * writer: an error, a full disk, a signal. */

namespace pcl_parallel {
namespace io {

/** Thrown (by a write callback or anything it calls) to stop a write for a reason that
 *  is not the file's, e.g. a signal: writeAtomically removes the temporary file and
 *  passes it on unchanged instead of naming the file in it. */
struct WriteAborted : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/** Calls write(tmp) with a temporary path beside `path` (".NAME.tmpPID"), then renames it
 *  to `path`. On an exception the temporary file is removed and the exception passed on:
 *  a WriteAborted, and what is no std::exception, unchanged; any other std::exception as
 *  std::runtime_error "PATH: what" (a leading "TMP: " of `what` dropped), so a message
 *  names the file asked for, not its temporary. */
void
writeAtomically(const std::string& path, const std::function<void(const std::string&)>& write);

/** Whether a file name is one of writeAtomically's temporaries (".NAME.tmpPID"), as a
 *  writer that was killed leaves it. */
bool
isAtomicWriteTemporary(const std::string& name);

/** writeAtomically through a binary std::ofstream that is opened, closed and checked here:
 *  "PATH: cannot open for writing (REASON)", "PATH: write error (REASON)" (a full disk
 *  shows at the latest when the buffer is written out, so the close is checked too). */
void
writeStreamAtomically(const std::string& path, const std::function<void(std::ostream&)>& body);

} // namespace io
} // namespace pcl_parallel
