/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "file_names.h"

#include <pcl_parallel/io/atomic_write.h>
#include <pcl_parallel/io/output_directory.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio> // renameat2, RENAME_EXCHANGE (glibc)
#include <cstring>
#include <dirent.h>
#include <fcntl.h> // AT_FDCWD, open
#include <filesystem>
#include <string>
#include <string_view>
#include <sys/syscall.h>
#include <unistd.h>
#include <vector>

namespace pcl_parallel {
namespace io {

namespace fs = std::filesystem;

namespace {

std::string
hostName()
{
  char name[256] = {0};
  if (::gethostname(name, sizeof name - 1) != 0)
    return "localhost";
  return name;
}

/** The pid in "PREFIXHOST-PID" followed by nothing or by '.'; 0 where `name` is not one of
 *  this host's. */
long
temporaryPid(const std::string& name, const std::string& prefix)
{
  const std::string head = prefix + hostName() + "-";
  if (name.compare(0, head.size(), head) != 0)
    return 0;
  const std::size_t digits = detail::leadingDigits(std::string_view(name).substr(head.size()));
  const std::size_t end = head.size() + digits;
  if (digits == 0 || digits > 18 || (end < name.size() && name[end] != '.'))
    return 0; // no pid, or more digits than a long holds
  return std::stol(name.substr(head.size(), digits));
}

/** The target as a path without a trailing slash, a link to a directory resolved (the
 *  directory is swapped, the link kept). */
fs::path
targetPath(const std::string& target)
{
  fs::path p = fs::absolute(target).lexically_normal();
  if (p.filename().empty())
    p = p.parent_path();
  std::error_code ec;
  if (fs::is_symlink(p, ec) && fs::is_directory(p, ec))
    p = fs::canonical(p, ec);
  if (p.filename().empty() || p == p.root_path())
    throw OutputDirectoryError(target +
                               ": the file system's root cannot be an output directory");
  return p;
}

/** Throws unless `dir` holds only names `owned` accepts (or temporaries); true where it holds
 *  any (an earlier run's outputs). */
bool
holdsEarlierRun(const fs::path& dir, const OutputNamePredicate& owned)
{
  std::vector<std::string> foreign;
  bool any = false;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    any = true;
    if (!(it->is_regular_file(ec) && (owned(name) || isAtomicWriteTemporary(name))))
      foreign.push_back(name);
  }
  if (ec)
    throw OutputDirectoryError(dir.string() + ": cannot list the output directory (" +
                               ec.message() + ")");
  if (!foreign.empty()) {
    std::sort(foreign.begin(), foreign.end());
    std::string names;
    for (std::size_t k = 0; k < foreign.size() && k < 3; ++k)
      names += (k ? ", " : "") + foreign[k];
    throw OutputDirectoryError(
        dir.string() + ": the output directory holds what no run wrote (" + names +
        (foreign.size() > 3 ? ", ..." : "") +
        "); choose a new or empty directory, or one holding an earlier run's outputs");
  }
  return any;
}

/** The registered temporary directories: a slot's path is complete before its flag is
 *  set, so a signal handler reads whole paths only. */
struct TemporarySlot {
  volatile std::sig_atomic_t used = 0;
  char path[4096] = {};
};
TemporarySlot g_temporaries[8];

/** `dir` and its files, by system calls alone (async-signal-safe). */
void
removeFlatDirectory(const char* dir) noexcept
{
#if defined(__linux__)
  const int fd = ::open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd >= 0) {
    alignas(8) char buffer[4096];
    for (long n; (n = ::syscall(SYS_getdents64, fd, buffer, sizeof buffer)) > 0;)
      for (long at = 0; at < n;) {
        const auto* entry = reinterpret_cast<const struct dirent64*>(buffer + at);
        ::unlinkat(fd, entry->d_name, 0); // fails, harmlessly, for "." and ".."
        at += entry->d_reclen;
      }
    ::close(fd);
  }
#endif
  ::rmdir(dir);
}

void
registerTemporary(const std::string& dir)
{
  for (TemporarySlot& slot : g_temporaries)
    if (!slot.used && dir.size() < sizeof slot.path) {
      dir.copy(slot.path, dir.size());
      slot.path[dir.size()] = '\0';
      slot.used = 1;
      return;
    }
}

void
unregisterTemporary(const std::string& dir)
{
  for (TemporarySlot& slot : g_temporaries)
    if (slot.used && dir == slot.path)
      slot.used = 0;
}

/** Creates "PREFIXHOST-PID.N" in `dir`, after removing those of ended processes, and
 *  registers it for removeTemporariesNow(). Returns its path; `ec` is set where it could not
 *  be created. */
std::string
createTemporary(const fs::path& dir, const std::string& prefix, std::error_code& ec)
{
  removeStaleTemporaries(dir.string(), prefix);
  static std::atomic<int> serial{0}; // several in one process (tests)
  const std::string path =
      (dir / (temporaryName(prefix) + "." + std::to_string(serial++))).string();
  if (!fs::create_directory(path, ec) && !ec)
    ec = std::make_error_code(std::errc::file_exists);
  if (!ec)
    registerTemporary(path);
  return path;
}

} // namespace

void
removeTemporariesNow() noexcept
{
  for (const TemporarySlot& slot : g_temporaries)
    if (slot.used)
      removeFlatDirectory(slot.path);
}

bool
isRunOutputName(const std::string& name)
{
  using detail::isNumberedName;
  return isNumberedName(name, "scan", 0, {".frames"}) ||
         isNumberedName(name, "map_rank", 0, {".pcd", ".ply"}) ||
         detail::isOneOf(name,
                         {"poses.txt",
                          "poses_icp.txt",
                          "poses_tum.txt",
                          "poses_icp_tum.txt",
                          "map.pcd",
                          "map.ply",
                          "map.png",
                          "graph.g2o",
                          "report.json"});
}

std::string
temporaryName(const std::string& prefix)
{
  return prefix + hostName() + "-" + std::to_string(::getpid());
}

std::size_t
removeStaleTemporaries(const std::string& dir, const std::string& prefix)
{
  std::vector<fs::path> stale;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const long pid = temporaryPid(it->path().filename().string(), prefix);
    if (pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH)
      stale.push_back(it->path());
  }
  for (const fs::path& p : stale)
    fs::remove_all(p, ec);
  return stale.size();
}

TemporaryDirectory::TemporaryDirectory(const std::string& prefix)
{
  std::error_code ec;
  path_ = createTemporary(fs::temp_directory_path(), prefix, ec);
  if (ec)
    throw std::runtime_error(path_ + ": cannot create a temporary directory (" + ec.message() +
                             ")");
}

TemporaryDirectory::~TemporaryDirectory()
{
  unregisterTemporary(path_);
  std::error_code ec;
  fs::remove_all(path_, ec);
}

OutputDirectory::OutputDirectory(const std::string& target, OutputNamePredicate owned)
{
  const fs::path t = targetPath(target);
  target_ = t.string();
  std::error_code ec;
  if (fs::exists(t, ec)) {
    if (!fs::is_directory(t, ec))
      throw OutputDirectoryError(target + ": exists and is not a directory");
    replaces_ = holdsEarlierRun(t, owned);
  }
  const fs::path parent = t.parent_path();
  fs::create_directories(parent, ec);
  if (ec || !fs::is_directory(parent))
    throw OutputDirectoryError(parent.string() + ": cannot create the directory (" +
                               (ec ? ec.message() : "not a directory") + ")");
  path_ = createTemporary(parent, "." + t.filename().string() + ".pcl_pslam-", ec);
  if (ec)
    throw OutputDirectoryError(
        target + ": cannot create a temporary directory beside it (" + ec.message() +
        "): the outputs are written there and swapped in at the end; choose an output "
        "directory in a writable directory");
}

OutputDirectory::~OutputDirectory()
{
  unregisterTemporary(path_);
  std::error_code ec;
  if (!committed_)
    fs::remove_all(path_, ec);
}

void
OutputDirectory::commit()
{
  unregisterTemporary(path_); // from here on its name may hold the earlier run
  std::error_code ec;
  const bool occupied = fs::exists(target_, ec) && !fs::is_empty(target_, ec);
  if (!occupied) { // rename(2) replaces an empty directory
    fs::rename(path_, target_, ec);
    if (ec)
      throw OutputDirectoryError(target_ + ": cannot move the outputs into place (" +
                                 ec.message() + ")");
    committed_ = true;
    return;
  }
#ifdef RENAME_EXCHANGE
  if (::renameat2(AT_FDCWD, path_.c_str(), AT_FDCWD, target_.c_str(), RENAME_EXCHANGE) == 0) {
    committed_ = true;
    fs::remove_all(path_, ec); // the earlier run, now under the temporary name
    return;
  }
  if (errno != EINVAL && errno != ENOSYS && errno != ENOTSUP)
    throw OutputDirectoryError(target_ + ": cannot swap the outputs in (" +
                               std::strerror(errno) + ")");
#endif
  // A file system without the exchange: the earlier run aside, then the new one in.
  const std::string earlier = path_ + ".earlier";
  fs::rename(target_, earlier, ec);
  if (!ec) {
    fs::rename(path_, target_, ec);
    if (std::error_code back; ec)
      fs::rename(earlier, target_, back); // the target as it was
  }
  if (ec)
    throw OutputDirectoryError(target_ + ": cannot swap the outputs in (" + ec.message() + ")");
  committed_ = true;
  fs::remove_all(earlier, ec);
}

std::string
OutputDirectory::inTarget(std::string text) const
{
  for (std::size_t at = text.find(path_); at != std::string::npos;
       at = text.find(path_, at + target_.size()))
    text.replace(at, path_.size(), target_);
  return text;
}

} // namespace io
} // namespace pcl_parallel
