# ctest install_consumer (cmake -P): proves the installed package is usable.
#   1. cmake --install BUILD_DIR into WORK_DIR/prefix
#   2. configure CONSUMER_SOURCE_DIR with CMAKE_PREFIX_PATH=WORK_DIR/prefix, build it
#   3. run the consumer
# Inputs: BUILD_DIR, CONSUMER_SOURCE_DIR, WORK_DIR, CONFIG, C_COMPILER, CXX_COMPILER.
foreach(var BUILD_DIR CONSUMER_SOURCE_DIR WORK_DIR C_COMPILER CXX_COMPILER)
  if(NOT ${var})
    message(FATAL_ERROR "run_consumer_test.cmake: ${var} not set")
  endif()
endforeach()
if(NOT CONFIG)
  set(CONFIG Release)
endif()

function(run step)
  message(STATUS "install_consumer: ${step}: ${ARGN}")
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "install_consumer: ${step} failed (${rc})")
  endif()
endfunction()

set(prefix "${WORK_DIR}/prefix")
set(consumer_build "${WORK_DIR}/build")
file(REMOVE_RECURSE "${WORK_DIR}")

run(install "${CMAKE_COMMAND}" --install "${BUILD_DIR}" --config "${CONFIG}" --prefix "${prefix}")
# The source tree must not leak into the consumer: headers come from the prefix only.
if(NOT EXISTS "${prefix}/include/pcl_parallel/search/kdtree.h")
  message(FATAL_ERROR "install_consumer: headers were not installed under ${prefix}/include")
endif()
run(configure "${CMAKE_COMMAND}" -S "${CONSUMER_SOURCE_DIR}" -B "${consumer_build}"
    "-DCMAKE_PREFIX_PATH=${prefix}" "-DCMAKE_BUILD_TYPE=${CONFIG}"
    "-DCMAKE_C_COMPILER=${C_COMPILER}" "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
run(build "${CMAKE_COMMAND}" --build "${consumer_build}" --config "${CONFIG}")
run(run "${consumer_build}/pcl_parallel_consumer")
