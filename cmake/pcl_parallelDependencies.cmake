# Dependencies of pcl_parallel, found the same way by our build and by the installed
# pcl_parallelConfig.cmake (which includes this file).
#
# From the config (inside find_package(pcl_parallel)) find_dependency forwards REQUIRED and
# QUIET; in our own build there is no enclosing find_package, so find_package(... REQUIRED)
# is used directly (find_dependency would make a missing dependency non-fatal there).
if(CMAKE_FIND_PACKAGE_NAME)
  include(CMakeFindDependencyMacro)
  macro(_pcl_parallel_find_dependency)
    find_dependency(${ARGN})
  endmacro()
else()
  macro(_pcl_parallel_find_dependency)
    find_package(${ARGN} REQUIRED)
  endmacro()
endif()

# Debian's PCLConfig.cmake loads VTK (for pcl_io), whose imported targets reference
# MPI::MPI_C; without MPI found first, generation fails. FindMPI's C component needs the C
# language, which a consumer's project(... LANGUAGES CXX) does not enable.
if(NOT CMAKE_C_COMPILER_LOADED)
  enable_language(C)
endif()
_pcl_parallel_find_dependency(MPI COMPONENTS C)
_pcl_parallel_find_dependency(PCL 1.13 COMPONENTS common search kdtree registration io)
_pcl_parallel_find_dependency(Eigen3 3.3)
_pcl_parallel_find_dependency(OpenMP COMPONENTS CXX)
# Boost.Iostreams' bzip2 filter (io/carmen.cpp reads .clf.bz2): linked privately, but a
# static pcl_parallel's users link it too. PCL needs it as well (its pcl_io).
_pcl_parallel_find_dependency(Boost 1.65 COMPONENTS iostreams)
# Cairo (render/: the map's picture), by pkg-config as Debian ships it (libcairo2-dev):
# linked privately, but a static pcl_parallel's users link it too.
_pcl_parallel_find_dependency(PkgConfig)
if(NOT TARGET PkgConfig::PCL_PARALLEL_CAIRO)
  if(CMAKE_FIND_PACKAGE_NAME)
    pkg_check_modules(PCL_PARALLEL_CAIRO QUIET IMPORTED_TARGET cairo)
    if(NOT PCL_PARALLEL_CAIRO_FOUND)
      set(${CMAKE_FIND_PACKAGE_NAME}_FOUND FALSE)
      set(${CMAKE_FIND_PACKAGE_NAME}_NOT_FOUND_MESSAGE "cairo not found by pkg-config")
      return()
    endif()
  else()
    pkg_check_modules(PCL_PARALLEL_CAIRO REQUIRED IMPORTED_TARGET cairo)
  endif()
endif()
