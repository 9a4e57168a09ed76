# `mpirun -np N pcl_pslam run` against one process (issue 12): for N = 1, 2, 3 (threads
# per rank alternating 1 and 2) the poses are bit-identical to `pcl_pslam run` with the
# same --segment-size in one process without a launcher, every run exits 0, and the
# outputs are complete: poses, frames, report.json and map.png once, the map as one tile
# per rank (map_rank<r>.pcd) with several ranks, an empty one for a rank without a segment;
# no rank keeps every scan's points.
#   cmake -DPSLAM=exe -DMPIRUN="mpiexec|flags" -DNP_FLAG=-n -DDIR=scans -DOUT=dir -P ...
cmake_minimum_required(VERSION 3.19)
string(REPLACE "|" ";" mpirun "${MPIRUN}")
set(args run ${DIR} -q --segment-size 4 --segment-overlap 3)
file(REMOVE_RECURSE ${OUT})

function(check_run what rc out err)
  if(NOT rc STREQUAL "0")
    message(FATAL_ERROR "${what}: exit status ${rc}:\n${out}${err}")
  endif()
endfunction()

execute_process(COMMAND ${PSLAM} ${args} -t 2 --out ${OUT}/alone
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
check_run("one process" "${rc}" "${out}" "${err}")
if(NOT out MATCHES "pLUM: [1-9][0-9]* loop links?")
  message(FATAL_ERROR "the reference run closed no loop (nothing for pLUM over ranks):\n${out}")
endif()
file(SHA256 ${OUT}/alone/poses.txt reference)
file(SHA256 ${OUT}/alone/poses_icp.txt reference_icp)

foreach(np 1 2 3)
  math(EXPR threads "${np} % 2 + 1")
  execute_process(COMMAND ${mpirun} ${NP_FLAG} ${np} ${PSLAM} ${args} -t ${threads}
    --out ${OUT}/np${np} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  check_run("mpirun ${NP_FLAG} ${np}" "${rc}" "${out}" "${err}")
  # One summary (rank 0's), not one per rank.
  string(REGEX MATCHALL "pLUM: " summaries "${out}")
  list(LENGTH summaries n)
  if(NOT n EQUAL 1)
    message(FATAL_ERROR "np ${np}: ${n} summaries, expected 1:\n${out}")
  endif()
  file(SHA256 ${OUT}/np${np}/poses.txt poses)
  file(SHA256 ${OUT}/np${np}/poses_icp.txt poses_icp)
  if(NOT poses STREQUAL reference OR NOT poses_icp STREQUAL reference_icp)
    message(FATAL_ERROR "np ${np}: poses differ from the one-process run")
  endif()
  set(files poses_tum.txt scan000.frames map.png report.json)
  if(np EQUAL 1)
    list(APPEND files map.pcd)
  else()
    math(EXPR last "${np} - 1")
    foreach(r RANGE ${last})
      list(APPEND files map_rank${r}.pcd)
    endforeach()
  endif()
  foreach(f ${files})
    if(NOT EXISTS ${OUT}/np${np}/${f})
      message(FATAL_ERROR "np ${np}: ${f} missing")
    endif()
  endforeach()
  file(GLOB left ${OUT}/np${np}/*.tmp* ${OUT}/np${np}/.*)
  if(left)
    message(FATAL_ERROR "np ${np}: temporaries left: ${left}")
  endif()
endforeach()
# The tiles together are the map: each of the one process's voxels is in at least one tile
# (a tile missing or cut short would drop some), in at most one per rank.
file(READ ${OUT}/alone/report.json report)
string(JSON alone GET "${report}" map points)
string(JSON last_alone GET "${report}" scans 10 points)
foreach(np 2 3)
  file(READ ${OUT}/np${np}/report.json report)
  string(JSON ranks GET "${report}" segments ranks)
  string(JSON tiles GET "${report}" map points)
  string(JSON last GET "${report}" scans 10 points) # read by the last rank, reported by 0
  if(NOT last EQUAL last_alone OR last EQUAL 0)
    message(FATAL_ERROR "np ${np}: report.json gives scan 10 ${last} points (alone: "
      "${last_alone})")
  endif()
  # No rank keeps the whole survey's points (its own scans and its links' others only).
  string(JSON kept GET "${report}" segments max_kept_scans)
  string(JSON num_scans LENGTH "${report}" scans)
  if(NOT kept GREATER 0 OR NOT kept LESS num_scans)
    message(FATAL_ERROR "np ${np}: a rank keeps ${kept} of ${num_scans} scans")
  endif()
  math(EXPR most "${alone} * ${np}")
  if(NOT ranks EQUAL np OR tiles LESS alone OR tiles GREATER most)
    message(FATAL_ERROR "np ${np}: report.json says ${ranks} ranks, ${tiles} map points "
      "in the tiles (one process: ${alone})")
  endif()
endforeach()
# More ranks than segments: the rank without one writes an empty tile, and the run ends
# as any other.
execute_process(COMMAND ${mpirun} ${NP_FLAG} 3 ${PSLAM} run ${DIR} -q --segment-size 6 -t 1
  --out ${OUT}/idle_rank RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
check_run("3 ranks, 2 segments" "${rc}" "${out}" "${err}")
foreach(f map_rank0.pcd map_rank1.pcd map_rank2.pcd map.png report.json)
  if(NOT EXISTS ${OUT}/idle_rank/${f})
    message(FATAL_ERROR "3 ranks, 2 segments: ${f} missing")
  endif()
endforeach()
message(STATUS "poses bit-identical for 1, 2, 3 ranks and one process")
