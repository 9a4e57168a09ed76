/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include <pcl_parallel/io/stderr_capture.h>

#include <cctype>
#include <map>
#include <unistd.h>
#include <utility>

namespace pcl_parallel {
namespace io {

StderrCapture::StderrCapture()
{
  std::fflush(stderr);
  std::FILE* capture = std::tmpfile();
  const int saved = capture ? ::dup(2) : -1;
  std::FILE* terminal = saved >= 0 ? ::fdopen(::dup(saved), "w") : nullptr;
  if (!terminal || ::dup2(::fileno(capture), 2) < 0) { // no capture: print as PCL does
    if (terminal)
      std::fclose(terminal);
    if (saved >= 0)
      ::close(saved);
    if (capture)
      std::fclose(capture);
    return;
  }
  capture_ = capture;
  terminal_ = terminal;
  saved_ = saved;
}

StderrCapture::~StderrCapture()
{
  if (!capture_)
    return;
  std::fflush(stderr);
  ::dup2(saved_, 2);
  ::close(saved_);
  std::fclose(terminal_);
  std::fclose(capture_);
}

std::vector<std::string>
StderrCapture::take()
{
  if (!capture_)
    return {};
  std::fflush(stderr);
  std::fseek(capture_, read_, SEEK_SET);
  // Keyed by the line with each run of digits as one '#'.
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
  std::fseek(capture_, 0, SEEK_END); // where descriptor 2 writes next
  std::vector<std::string> lines;
  for (const auto& key : order) {
    const auto& [count, first] = kinds[key];
    lines.push_back(
        count == 1 ? first : first + "  (and " + std::to_string(count - 1) + " more like it)");
  }
  return lines;
}

} // namespace io
} // namespace pcl_parallel
