/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "file_names.h"

#include <pcl_parallel/io/atomic_write.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string_view>
#include <system_error>
#include <unistd.h>

namespace pcl_parallel {
namespace io {

namespace fs = std::filesystem;

namespace {

/** The reason of the last failed system call, for a message ("" when unknown). */
std::string
reason()
{
  return errno ? std::string(" (") + std::strerror(errno) + ")" : std::string();
}

} // namespace

bool
isAtomicWriteTemporary(const std::string& name)
{
  // .NAME.tmpN, as writeAtomically names them: the last ".tmp" is followed by digits alone.
  const std::size_t tmp = name.rfind(".tmp");
  return name.size() > 1 && name[0] == '.' && tmp != std::string::npos && tmp >= 2 &&
         detail::isNumberedName(std::string_view(name).substr(tmp), ".tmp", 0, {""});
}

void
writeAtomically(const std::string& path, const std::function<void(const std::string&)>& write)
{
  const fs::path p(path);
  const std::string tmp =
      (p.parent_path() / ("." + p.filename().string() + ".tmp" + std::to_string(::getpid())))
          .string();
  auto removeTmp = [&] {
    std::error_code ec;
    fs::remove(tmp, ec);
  };
  try {
    write(tmp);
    std::error_code ec;
    fs::rename(tmp, path, ec);
    if (ec)
      throw std::runtime_error("cannot rename the written file into place: " + ec.message());
  }
  catch (const WriteAborted&) {
    removeTmp();
    throw;
  }
  catch (const std::exception& e) { // named by the file asked for, not its temporary
    removeTmp();
    std::string what = e.what();
    if (what.rfind(tmp + ": ", 0) == 0)
      what.erase(0, tmp.size() + 2);
    throw std::runtime_error(path + ": " + what);
  }
  catch (...) {
    removeTmp();
    throw;
  }
}

void
writeStreamAtomically(const std::string& path, const std::function<void(std::ostream&)>& body)
{
  writeAtomically(path, [&](const std::string& tmp) {
    errno = 0; // then the failed open's or write's
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out)
      throw std::runtime_error("cannot open for writing" + reason());
    body(out);
    out.close();
    if (!out)
      throw std::runtime_error("write error" + reason());
  });
}

} // namespace io
} // namespace pcl_parallel
