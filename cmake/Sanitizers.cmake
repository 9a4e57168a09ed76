# pcl_parallel_sanitize(target): instruments our own targets with the sanitizers named in
# PCL_PARALLEL_SANITIZE. Only our code is instrumented; PCL, FLANN and Boost come from
# Debian's uninstrumented packages.
function(pcl_parallel_sanitize target)
  if(NOT PCL_PARALLEL_SANITIZE)
    return()
  endif()
  set(flags -fsanitize=${PCL_PARALLEL_SANITIZE} -fno-omit-frame-pointer -g)
  if(PCL_PARALLEL_SANITIZE MATCHES "undefined")
    list(APPEND flags -fno-sanitize-recover=undefined)
  endif()
  target_compile_options(${target} PRIVATE ${flags})
  target_link_options(${target} PUBLIC -fsanitize=${PCL_PARALLEL_SANITIZE})
endfunction()
