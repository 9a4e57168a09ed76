# Install the library, its headers and a relocatable CMake package:
#   find_package(pcl_parallel REQUIRED)
#   target_link_libraries(app PRIVATE pcl_parallel::pcl_parallel)
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(PCL_PARALLEL_CMAKE_DIR "${CMAKE_INSTALL_LIBDIR}/cmake/pcl_parallel")

install(TARGETS pcl_parallel EXPORT pcl_parallelTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# (The include directory is already in the target's INSTALL_INTERFACE; an INCLUDES
# DESTINATION here would list it twice in the exported target.)
set(_pcl_parallel_exclude "")
if(NOT PCL_PARALLEL_WITH_MPI) # mpi/ is built only with MPI
  set(_pcl_parallel_exclude PATTERN mpi EXCLUDE)
endif()
install(DIRECTORY include/pcl_parallel DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
  ${_pcl_parallel_exclude})
install(EXPORT pcl_parallelTargets NAMESPACE pcl_parallel::
  DESTINATION ${PCL_PARALLEL_CMAKE_DIR})

configure_package_config_file(cmake/pcl_parallelConfig.cmake.in
  "${PROJECT_BINARY_DIR}/pcl_parallelConfig.cmake"
  INSTALL_DESTINATION ${PCL_PARALLEL_CMAKE_DIR})
write_basic_package_version_file("${PROJECT_BINARY_DIR}/pcl_parallelConfigVersion.cmake"
  COMPATIBILITY SameMinorVersion)
install(FILES
  "${PROJECT_BINARY_DIR}/pcl_parallelConfig.cmake"
  "${PROJECT_BINARY_DIR}/pcl_parallelConfigVersion.cmake"
  cmake/pcl_parallelDependencies.cmake
  DESTINATION ${PCL_PARALLEL_CMAKE_DIR})
