/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <filesystem>
#include <fstream>
#include <gtest/gtest.h>
#include <string>
#include <unistd.h>

namespace pcl_parallel {
namespace test {

/** A fresh directory for one test, named after it, removed again at the end. */
class ScratchDir {
public:
  ScratchDir()
  {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::temp_directory_path() /
            ("pcl_parallel_" + std::string(info->test_suite_name()) + "_" + info->name() + "_" +
             std::to_string(::getpid()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir()
  {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir&
  operator=(const ScratchDir&) = delete;

  /** Path of a file in the directory. */
  std::string
  operator/(const std::string& name) const
  {
    return (path_ / name).string();
  }

  /** Writes text to a file in the directory; returns its path. */
  std::string
  write(const std::string& name, const std::string& text) const
  {
    const std::string p = *this / name;
    std::ofstream(p) << text;
    return p;
  }

  std::string
  str() const
  {
    return path_.string();
  }

private:
  std::filesystem::path path_;
};

} // namespace test
} // namespace pcl_parallel
