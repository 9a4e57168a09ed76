/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <exception>
#include <gtest/gtest.h>
#include <string>

namespace pcl_parallel {
namespace test {

/** The message of the Exception that f throws (a test failure, and "", if it throws none;
 *  another exception type escapes, failing the test). */
template <typename Exception = std::exception, typename F>
std::string
messageOf(F&& f)
{
  try {
    f();
  }
  catch (const Exception& e) {
    return e.what();
  }
  ADD_FAILURE() << "no exception";
  return "";
}

} // namespace test
} // namespace pcl_parallel
