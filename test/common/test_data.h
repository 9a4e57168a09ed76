/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <filesystem>
#include <gtest/gtest.h>
#include <string>

namespace pcl_parallel {
namespace test {

/** Reference data directory (CMake cache variable PCL_PARALLEL_DATA_DIR; the environment
 *  variable of the same name overrides it). */
inline std::string
dataDir()
{
  if (const char* env = std::getenv("PCL_PARALLEL_DATA_DIR"))
    return env;
  return PCL_PARALLEL_DATA_DIR;
}

/** Path of a data file, or "" when it is absent. */
inline std::string
dataFile(const std::string& relative)
{
  const std::filesystem::path p = std::filesystem::path(dataDir()) / relative;
  return std::filesystem::exists(p) ? p.string() : std::string();
}

/** Built with a sanitizer (scripts/test.sh asan, tsan), where a test runs 5-20 times
 *  slower and is there for memory errors and races, not accuracy: the heaviest tests then
 *  run a smaller problem through the same code paths. */
#ifdef PCL_PARALLEL_SANITIZED
inline constexpr bool kSanitized = true;
#else
inline constexpr bool kSanitized = false;
#endif

} // namespace test
} // namespace pcl_parallel

/** Sets `var` to the data file's path, or skips the test with a clear message. */
#define PCL_PARALLEL_REQUIRE_DATA(var, relative)                                               \
  const std::string var = ::pcl_parallel::test::dataFile(relative);                            \
  if (var.empty())                                                                             \
  GTEST_SKIP() << "reference data " << (relative) << " not found under "                       \
               << ::pcl_parallel::test::dataDir()                                              \
               << " (set -DPCL_PARALLEL_DATA_DIR or the environment variable)"
