/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <functional>
#include <stdexcept>
#include <string>

/* A run's outputs are one unit: they are written into a fresh temporary directory beside the
 * target and swapped in at the end (one rename; with an earlier run there, Linux's atomic
 * exchange), so the target holds one run's complete outputs or its previous state, whatever
 * ends the run. docs/design.md, "Outputs". */

namespace pcl_parallel {
namespace io {

/** The target cannot be used: it is a file, holds files no run wrote, cannot be created. */
struct OutputDirectoryError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/** Whether a file name in an output directory is one the run's kind writes (an earlier
 *  run's outputs are replaced; anything else makes the target refused). */
using OutputNamePredicate = std::function<bool(const std::string& name)>;

/** The files `pcl_pslam run` writes: scanNNN.frames, poses*.txt, map.{pcd,ply,png},
 *  map_rankN.{pcd,ply}, graph.g2o, report.json. */
bool
isRunOutputName(const std::string& name);

/**
 * The temporary directory a run writes into, and its swap into the target.
 *
 * The constructor checks the target (absent, empty, or holding only names `owned` accepts
 * and writeAtomically's temporaries), creates its missing parents and
 * ".NAME.pcl_pslam-HOST-PID.tmp" beside it, after removing such directories of runs on this
 * host that no longer exist (killed). commit() renames it over the target; the destructor
 * removes it unless committed, and removeTemporariesNow() (a signal) at any time before.
 */
class OutputDirectory {
public:
  /** Prepares `target` (see above); throws OutputDirectoryError naming it where it cannot
   *  be used. */
  OutputDirectory(const std::string& target, OutputNamePredicate owned);
  ~OutputDirectory();
  OutputDirectory(const OutputDirectory&) = delete;
  OutputDirectory&
  operator=(const OutputDirectory&) = delete;

  /** Where the outputs go until commit(). */
  const std::string&
  path() const
  {
    return path_;
  }
  /** Where they are after commit(). */
  const std::string&
  target() const
  {
    return target_;
  }
  /** Whether the target held an earlier run's outputs (replaced by commit()). */
  bool
  replacesEarlierRun() const
  {
    return replaces_;
  }

  /** Swaps the outputs in: the target is the new run's, the earlier run's removed. Throws
   *  OutputDirectoryError naming the target if the rename fails (the target then is as it
   *  was). */
  void
  commit();

  /** `text` with the temporary directory's path replaced by the target's (for messages
   *  naming an output file). */
  std::string
  inTarget(std::string text) const;

private:
  std::string target_, path_;
  bool replaces_ = false, committed_ = false;
};

/** A fresh directory in the system's temporary folder, "PREFIXHOST-PID.N" (those of ended
 *  processes removed first), removed with its files by the destructor or a signal
 *  (removeTemporariesNow): scans written to be read back, e.g. a simulated set. */
class TemporaryDirectory {
public:
  /** Creates the directory, named from `prefix`; throws std::runtime_error where it cannot. */
  explicit TemporaryDirectory(const std::string& prefix);
  ~TemporaryDirectory();
  TemporaryDirectory(const TemporaryDirectory&) = delete;
  TemporaryDirectory&
  operator=(const TemporaryDirectory&) = delete;

  /** The directory's path. */
  const std::string&
  path() const
  {
    return path_;
  }

private:
  std::string path_;
};

/** Removes the temporary directories of this process (each OutputDirectory's until its
 *  commit() or destruction, each TemporaryDirectory's; at most 8 at a time) with their
 *  files, by system calls alone: async-signal-safe, for a signal handler that ends the
 *  process at once. Subdirectories, which none of these has, stay. */
void
removeTemporariesNow() noexcept;

/** Removes the directories "PREFIXHOST-PID*" in `dir` whose process on this host has
 *  ended (a run killed before it could remove its temporaries). Returns how many. */
std::size_t
removeStaleTemporaries(const std::string& dir, const std::string& prefix);

/** "PREFIXHOST-PID": a temporary's name for this process (removeStaleTemporaries). */
std::string
temporaryName(const std::string& prefix);

} // namespace io
} // namespace pcl_parallel
