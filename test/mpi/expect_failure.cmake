# Runs CMD ('|'-separated) and checks that it fails (exit status not 0) with output
# matching EXPECT_REGEX, and (with ONCE) that ONCE matches exactly once in it (one rank
# speaks for all):
#   cmake -DCMD="prog|arg" -DEXPECT_REGEX=RE [-DONCE=RE] -P expect_failure.cmake
string(REPLACE "|" ";" cmd "${CMD}")
execute_process(COMMAND ${cmd} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(rc STREQUAL "0")
  message(FATAL_ERROR "exit status 0, expected a failure; output:\n${out}${err}")
endif()
if(NOT "${out}${err}" MATCHES "${EXPECT_REGEX}")
  message(FATAL_ERROR "output does not match '${EXPECT_REGEX}':\n${out}${err}")
endif()
if(ONCE)
  string(REGEX MATCHALL "${ONCE}" found "${out}${err}")
  list(LENGTH found n)
  if(NOT n EQUAL 1)
    message(FATAL_ERROR "'${ONCE}' found ${n} times, expected once:\n${out}${err}")
  endif()
endif()
message(STATUS "exit status ${rc}; output:\n${out}${err}")
