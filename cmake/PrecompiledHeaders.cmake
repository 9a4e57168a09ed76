# Precompiled headers for our own targets (option PCL_PARALLEL_PRECOMPILE_HEADERS, on by
# default; CMake >= 3.16). Most of a translation unit's compile time here is parsing Eigen's
# and PCL's headers (pipeline.cpp: 7 of its 10.5 s at -O3), and every build of
# scripts/test.sh (release, ASan, TSan, fuzz) parses them again in each unit. These are the
# third-party headers most units include; our own headers stay out, so editing one does not
# rebuild the header for everything.
#
#   pcl_parallel_precompile_headers(target)              its own precompiled header
#   pcl_parallel_precompile_headers(target REUSE other)  other's (same compile flags, e.g.
#                                                        every test executable)
#
# CMake compiles with -Winvalid-pch: a unit whose flags do not fit the header falls back to
# parsing the headers as text (correct, only slower), with a warning.
#
# Units that instantiate PCL's ICP (src/registration/icp.cpp, test/test_icp.cpp,
# apps/pcl_parallel_bench/bench_icp.cpp) parse their headers as text
# (SKIP_PRECOMPILE_HEADERS): with Eigen from a precompiled header, GCC 12 reports
# -Warray-bounds / -Wuse-after-free false positives inside Eigen's umeyama, under PCL's
# TransformationEstimationSVD, which parsed as text it keeps quiet (icp.cpp, which warns
# either way, silences them with pragmas placed before its includes).
option(PCL_PARALLEL_PRECOMPILE_HEADERS "Precompile the Eigen/PCL headers of our targets" ON)

set(PCL_PARALLEL_PCH_HEADERS
  <algorithm> <cmath> <cstddef> <cstdint> <functional> <memory> <stdexcept> <string>
  <vector>
  <Eigen/Core> <Eigen/Geometry>
  <pcl/point_types.h> <pcl/point_cloud.h> <pcl/common/transforms.h> <pcl/console/print.h>
  <pcl/search/kdtree.h> <pcl/registration/registration.h>)

function(pcl_parallel_precompile_headers target)
  cmake_parse_arguments(P "" "REUSE" "EXTRA" ${ARGN})
  if(NOT PCL_PARALLEL_PRECOMPILE_HEADERS)
    return()
  endif()
  if(P_REUSE)
    target_precompile_headers(${target} REUSE_FROM ${P_REUSE})
  else()
    target_precompile_headers(${target} PRIVATE ${PCL_PARALLEL_PCH_HEADERS} ${P_EXTRA})
  endif()
endfunction()
