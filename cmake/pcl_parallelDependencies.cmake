# Dependencies of pcl_parallel, found the same way by our build and by the installed
# pcl_parallelConfig.cmake (which includes this file).
include(CMakeFindDependencyMacro)

# Debian's PCLConfig.cmake loads VTK (for pcl_io), whose imported targets reference
# MPI::MPI_C; without MPI found first, generation fails.
find_dependency(MPI COMPONENTS C)
find_dependency(PCL 1.13 COMPONENTS common search kdtree registration io)
find_dependency(Eigen3 3.3)
find_dependency(OpenMP COMPONENTS CXX)
