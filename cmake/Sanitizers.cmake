# Sanitizer builds, selected by the cache variable PCL_PARALLEL_SANITIZE:
#   ""                   none (default)
#   "address,undefined"  AddressSanitizer + UndefinedBehaviorSanitizer (GCC or Clang)
#   "thread"             ThreadSanitizer; use Clang with LLVM's OpenMP runtime (libomp) so the
#                        Archer OMPT tool can tell TSan about OpenMP's synchronisation:
#                          CC=clang-14 CXX=clang++-14 cmake -DPCL_PARALLEL_SANITIZE=thread ...
# scripts/test.sh builds and runs both. It exports the run-time options (ASAN_OPTIONS,
# LSAN_OPTIONS, UBSAN_OPTIONS, TSAN_OPTIONS with test/sanitizers/*.supp) before building,
# since gtest discovery runs the instrumented tests at build time too; copy them from there
# to run a sanitizer build by hand. In particular TSan needs ignore_noninstrumented_modules=1
# (Archer's advice: uninstrumented libomp, and libOpenNI2 loaded by libpcl_io, otherwise
# give false reports).
# OMP_TOOL_LIBRARIES (Archer) is set on the TSan tests by test/CMakeLists.txt.
#
# Only our own targets are instrumented (pcl_parallel_sanitize(target)); PCL, FLANN, Boost
# and VTK come from Debian's uninstrumented packages.

if(PCL_PARALLEL_SANITIZE AND NOT PCL_PARALLEL_SANITIZE MATCHES "^(address|undefined|thread)(,(address|undefined))*$")
  message(FATAL_ERROR "PCL_PARALLEL_SANITIZE='${PCL_PARALLEL_SANITIZE}': expected '', "
                      "'address,undefined' or 'thread'")
endif()

# ThreadSanitizer and OpenMP.
# TSan does not see the futex-based barriers, locks and task dependencies inside an
# uninstrumented OpenMP runtime, so without help every `omp parallel` looks racy. LLVM's
# libomp (unlike GCC's libgomp) implements the OMPT interface, through which the Archer tool
# (libarcher.so, loaded via OMP_TOOL_LIBRARIES) annotates that synchronisation for TSan.
#
# Debian's PCL and FLANN libraries are built with GCC and have DT_NEEDED libgomp.so.1, while
# our Clang-built code needs libomp.so.5. Loaded side by side, PCL's OpenMP regions would run
# on libgomp, invisible to Archer, and two thread pools would compete. libomp also exports
# libgomp's ABI (the GOMP_* entry points under the same GOMP_x.y / OMP_x.y symbol versions;
# LLVM installs libgomp.so -> libomp.so.5 for exactly this), so we let `libgomp.so.1` resolve
# to libomp: a directory in the build tree holds libgomp.so.1 -> libomp.so.5, and the
# instrumented executables carry it as DT_RPATH (--disable-new-dtags: unlike DT_RUNPATH, an
# executable's DT_RPATH is also searched for the dependencies of its libraries, here
# libpcl_*.so, which have no RUNPATH of their own). The dynamic loader recognises the
# symlink as the already loaded libomp.so.5 (same file), so one OpenMP runtime is used.
# `ldd build-tsan/test/test_kdtree` shows libgomp.so.1 => .../openmp-shim/libgomp.so.1.
set(PCL_PARALLEL_OPENMP_SHIM_DIR "")
if(PCL_PARALLEL_SANITIZE MATCHES "thread")
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(WARNING "PCL_PARALLEL_SANITIZE=thread with ${CMAKE_CXX_COMPILER_ID}: GCC's "
                    "libgomp has no Archer support, expect false reports from OpenMP "
                    "regions. Configure with CC=clang-14 CXX=clang++-14.")
  else()
    set(_omp_lib "")
    foreach(_lib IN LISTS OpenMP_CXX_LIBRARIES)
      if(_lib MATCHES "libomp[.]so")
        set(_omp_lib "${_lib}")
      endif()
    endforeach()
    if(NOT _omp_lib)
      message(FATAL_ERROR "ThreadSanitizer build: OpenMP for ${CMAKE_CXX_COMPILER} is not "
                          "LLVM's libomp (${OpenMP_CXX_LIBRARIES}); install libomp-14-dev")
    endif()
    get_filename_component(_omp_lib "${_omp_lib}" REALPATH) # file(REAL_PATH) needs 3.19
    set(PCL_PARALLEL_OPENMP_SHIM_DIR "${PROJECT_BINARY_DIR}/openmp-shim")
    file(MAKE_DIRECTORY "${PCL_PARALLEL_OPENMP_SHIM_DIR}")
    file(CREATE_LINK "${_omp_lib}" "${PCL_PARALLEL_OPENMP_SHIM_DIR}/libgomp.so.1" SYMBOLIC)
    get_filename_component(_omp_dir "${_omp_lib}" DIRECTORY)
    find_file(PCL_PARALLEL_ARCHER_LIBRARY libarcher.so HINTS "${_omp_dir}"
              DOC "LLVM's Archer OMPT tool, loaded through OMP_TOOL_LIBRARIES in TSan tests")
    if(NOT PCL_PARALLEL_ARCHER_LIBRARY)
      message(FATAL_ERROR "ThreadSanitizer build: libarcher.so not found next to ${_omp_lib}")
    endif()
  endif()
endif()

# pcl_parallel_sanitize(target): instruments one of our targets with PCL_PARALLEL_SANITIZE.
# -O1 and -g1 come after the build type's flags, so they win. -O1 keeps the instrumented
# code fast enough; -g1 (line tables and function names, no variables or types) is all a
# sanitizer's stack trace reads, and compiles PCL-heavy units in about 60 % of -g's time
# (lum_solver.cpp under ASan: 58 s instead of 102 s; objects a quarter the size).
function(pcl_parallel_sanitize target)
  if(NOT PCL_PARALLEL_SANITIZE)
    return()
  endif()
  set(flags -fsanitize=${PCL_PARALLEL_SANITIZE} -fno-omit-frame-pointer -O1 -g1)
  if(PCL_PARALLEL_SANITIZE MATCHES "undefined")
    list(APPEND flags -fno-sanitize-recover=undefined)
  endif()
  target_compile_options(${target} PRIVATE ${flags})
  if(PCL_PARALLEL_SANITIZE MATCHES "address")
    # Under -fsanitize=address Eigen stops trusting glibc's 16-byte aligned malloc
    # (__SANITIZE_ADDRESS__) and switches to its own offset allocator. Eigen objects then
    # cross into Debian's uninstrumented PCL, which frees them with plain free(): a bad
    # free. Keep the allocation scheme PCL was built with.
    target_compile_definitions(${target} PRIVATE EIGEN_MALLOC_ALREADY_ALIGNED=1)
  endif()
  target_link_options(${target} PUBLIC -fsanitize=${PCL_PARALLEL_SANITIZE})
  if(PCL_PARALLEL_OPENMP_SHIM_DIR)
    set_property(TARGET ${target} APPEND PROPERTY BUILD_RPATH "${PCL_PARALLEL_OPENMP_SHIM_DIR}")
    target_link_options(${target} PRIVATE -Wl,--disable-new-dtags)
  endif()
endfunction()
