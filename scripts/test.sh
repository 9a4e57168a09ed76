#!/usr/bin/env bash
# The test suite, as run by CI (.ci/run) and documented in README.md. From the repository root:
#
#   scripts/test.sh                 all stages
#   scripts/test.sh release tsan    only the stages named
#
# Stages (each in its own build directory, reused by later runs):
#   release  build/       Release build of everything; ctest (unit tests + install_consumer)
#   asan     build-asan/  AddressSanitizer + UndefinedBehaviorSanitizer (clang-14, -O1 -g1,
#                         no MPI), the tests labelled "asan" in test/CMakeLists.txt (all but
#                         MPI's and the accuracy studies), leaks checked, any UBSan finding
#                         fails. Clang, as it builds these units in half the time GCC takes
#   tsan     build-tsan/  ThreadSanitizer (clang-14, LLVM libomp + Archer, -O1 -g1, no MPI),
#                         only the tests labelled "tsan" in test/CMakeLists.txt
#   fuzz     build-fuzz/  libFuzzer + ASan/UBSan (clang-14) on every file reader
#                         (test/fuzz), FUZZ_SECONDS (default 10) each, nproc at a time,
#                         from seeds written by test/fuzz/write_fuzz_seeds; a finding
#                         fails the stage and leaves its input in build-fuzz/crashes/
# Prints the time of each stage at the end. Dependencies: scripts/install-deps.sh.
set -euo pipefail
cd "$(dirname "$0")/.."

jobs=$(nproc)
stages=("$@")
((${#stages[@]})) || stages=(release asan tsan fuzz)

timings=()
stage() { # stage NAME COMMAND...: runs and times one step
  local name=$1 start=$SECONDS
  shift
  echo "=== ${name}"
  "$@"
  timings+=("$(printf '%-16s %5ds' "$name" $((SECONDS - start)))")
}

# cmake_build DIR [cmake configure args...]: configure and build DIR
cmake_build() {
  local dir=$1
  shift
  mkdir -p "$dir"
  cmake -S . -B "$dir" "$@" >"$dir/configure.log" 2>&1 || {
    cat "$dir/configure.log"
    return 1
  }
  cmake --build "$dir" -j"$jobs"
}

release() {
  stage release-build cmake_build build -DCMAKE_BUILD_TYPE=Release
  stage release-ctest ctest --test-dir build --output-on-failure --no-tests=error -j2
}

asan() {
  # detect_leaks: LeakSanitizer at exit; suppressions: see the file for why each is benign.
  export ASAN_OPTIONS=detect_leaks=1:detect_stack_use_after_return=1:check_initialization_order=1
  export LSAN_OPTIONS=suppressions=$PWD/test/sanitizers/lsan.supp:print_suppressions=0
  export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  export CC=clang-14 CXX=clang++-14
  # No MPI: its tests run only in the release stage (test/CMakeLists.txt), so its units
  # would be compiled for nothing; the templates for the tests' point types only.
  stage asan-build cmake_build build-asan -DCMAKE_BUILD_TYPE=Debug \
    -DPCL_PARALLEL_SANITIZE=address,undefined -DPCL_PARALLEL_BUILD_APPS=OFF \
    -DPCL_PARALLEL_WITH_MPI=OFF -DPCL_PARALLEL_MINIMAL_POINT_TYPES=ON
  stage asan-ctest ctest --test-dir build-asan --output-on-failure --no-tests=error -j2 -L asan
  unset ASAN_OPTIONS LSAN_OPTIONS UBSAN_OPTIONS CC CXX
}

tsan() {
  # OMP_TOOL_LIBRARIES (Archer) is set on the tests by test/CMakeLists.txt. No MPI and the
  # tests' point types only, as in asan.
  export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 ignore_noninstrumented_modules=1 suppressions=$PWD/test/sanitizers/tsan.supp"
  export CC=clang-14 CXX=clang++-14
  stage tsan-build cmake_build build-tsan -DCMAKE_BUILD_TYPE=Debug \
    -DPCL_PARALLEL_SANITIZE=thread -DPCL_PARALLEL_BUILD_APPS=OFF -DPCL_PARALLEL_WITH_MPI=OFF \
    -DPCL_PARALLEL_MINIMAL_POINT_TYPES=ON
  stage tsan-ctest ctest --test-dir build-tsan --output-on-failure --no-tests=error -j2 -L tsan
  unset TSAN_OPTIONS CC CXX
}

fuzz() {
  local dir=build-fuzz bin=build-fuzz/test/fuzz secs=${FUZZ_SECONDS:-10}
  local targets=(uos_scan uos_pose frames xyz kitti_scan kitti_poses stanford_conf pcd ply
    kitti_times tum frames_history trajectory frames_dir evaluate options poses carmen
    relations)
  export CC=clang-14 CXX=clang++-14
  fuzz_build() {
    mkdir -p "$dir"
    cmake -S . -B "$dir" -DCMAKE_BUILD_TYPE=Debug -DPCL_PARALLEL_BUILD_FUZZERS=ON \
      -DPCL_PARALLEL_BUILD_TESTS=OFF -DPCL_PARALLEL_BUILD_APPS=OFF >"$dir/configure.log" 2>&1 || {
      cat "$dir/configure.log"
      return 1
    }
    cmake --build "$dir" -j"$jobs" --target fuzzers
  }
  # -malloc_limit_mb: a reader must reject a header's point count before allocating it.
  fuzz_one() {
    local t=$1
    mkdir -p "$dir/corpus/$t" "$dir/crashes"
    ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 \
      LSAN_OPTIONS=suppressions=$PWD/test/sanitizers/lsan.supp:print_suppressions=0 \
      "$bin/fuzz_$t" -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 \
      -malloc_limit_mb=1024 -artifact_prefix="$dir/crashes/$t-" -print_final_stats=1 \
      "$dir/corpus/$t" "$dir/seeds/$t" >"$dir/logs/$t.log" 2>&1
  }
  fuzz_run() {
    rm -rf "$dir/seeds" "$dir/logs" "$dir/crashes"
    mkdir -p "$dir/logs"
    "$bin/write_fuzz_seeds" "$dir/seeds"
    local pids=() names=() failed=0 i
    for t in "${targets[@]}"; do
      fuzz_one "$t" &
      pids+=($!)
      names+=("$t")
      if ((${#pids[@]} >= jobs)); then
        wait "${pids[0]}" || { failed=1; echo "fuzz_${names[0]}: FAILED"; tail -40 "$dir/logs/${names[0]}.log"; }
        pids=("${pids[@]:1}")
        names=("${names[@]:1}")
      fi
    done
    for i in "${!pids[@]}"; do
      wait "${pids[$i]}" || { failed=1; echo "fuzz_${names[$i]}: FAILED"; tail -40 "$dir/logs/${names[$i]}.log"; }
    done
    for t in "${targets[@]}"; do
      printf 'fuzz_%-14s %s\n' "$t" "$(grep -m1 -o 'stat::number_of_executed_units: *[0-9]*' "$dir/logs/$t.log" | grep -o '[0-9]*$') runs"
    done
    return $failed
  }
  stage fuzz-build fuzz_build
  stage fuzz-run fuzz_run
  unset CC CXX
}

total=$SECONDS
for s in "${stages[@]}"; do
  case "$s" in
  release | asan | tsan | fuzz) "$s" ;;
  *)
    echo "scripts/test.sh: unknown stage '$s' (release, asan, tsan, fuzz)" >&2
    exit 2
    ;;
  esac
done

echo "=== stage timings"
printf '%s\n' "${timings[@]}"
printf '%-16s %5ds\n' total $((SECONDS - total))
