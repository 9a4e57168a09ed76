/*
 * pcl_parallel: parallel scan matching (Nüchter, ECMR 2007) on top of PCL.
 * SPDX-License-Identifier: BSD-3-Clause
 *
 * libFuzzer entry points of one fuzz_<format> executable (see fuzz_readers.cpp).
 */
#include <cstddef>
#include <cstdint>

namespace pcl_parallel_fuzz {
void
initialize(const char* format);
void
testOneInput(const std::uint8_t* data, std::size_t size);
} // namespace pcl_parallel_fuzz

extern "C" int
LLVMFuzzerInitialize(int*, char***)
{
  pcl_parallel_fuzz::initialize(PCL_PARALLEL_FUZZ_FORMAT);
  return 0;
}

extern "C" int
LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
{
  pcl_parallel_fuzz::testOneInput(data, size);
  return 0;
}
