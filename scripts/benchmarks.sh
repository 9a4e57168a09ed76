#!/usr/bin/env bash
# Runs the benchmarks and regenerates docs/benchmarks.md, docs/reproduction.md and the plots
# in docs/images/ from their output alone. From the repository root, after a Release build:
#
#   scripts/benchmarks.sh              the full run (about 25 minutes on 2 idle cores)
#   scripts/benchmarks.sh --quick      a validation run: --repeats 1, fewer workloads
#                                      (a few minutes); the docs say "quick run" at the top
#   scripts/benchmarks.sh --report     only regenerate the docs from the results folder
#
# Options:
#   --bench PATH        pcl_parallel_bench      (env PCL_PARALLEL_BENCH, default build/apps/pcl_parallel_bench)
#   --pslam PATH        pcl_pslam               (env PCL_PSLAM, default build/apps/pcl_pslam)
#   --mpi-bench PATH    pcl_parallel_mpi_bench  (env PCL_PARALLEL_MPI_BENCH, default
#                       build/apps/pcl_parallel_mpi_bench; skipped when absent or without mpirun)
#   --data DIR          reference data          (env PCL_PARALLEL_DATA_DIR, default ../shared/data)
#   --results DIR       where each command's output goes (default build/benchmarks)
#   --threads LIST      thread counts (default 1, 2, 4, ... and nproc)
#   --repeats N         timed repeats per cell (default 3; --quick: 1)
#   --python-path DIR   the Python module's build folder (default build/python when it
#                       holds the module): runs apps/pcl_parallel_bench/python_gil.py
#   --accuracy          also run `pcl_parallel_bench accuracy` (the accuracy studies, minutes)
#   --no-mpi            leave out the MPI runs
#
# Every command's stdout, stderr and a .meta file (the command, start and end time, load
# average before and after) land in the results folder; machine.txt holds the machine.
# scripts/benchmarks_report.py writes the docs from that folder (Python 3 with matplotlib:
# Debian's python3-matplotlib; PYTHON picks the interpreter, default /usr/bin/python3).
set -euo pipefail
cd "$(dirname "$0")/.."

bench=${PCL_PARALLEL_BENCH:-build/apps/pcl_parallel_bench}
pslam=${PCL_PSLAM:-build/apps/pcl_pslam}
mpi_bench=${PCL_PARALLEL_MPI_BENCH:-build/apps/pcl_parallel_mpi_bench}
data=${PCL_PARALLEL_DATA_DIR:-../shared/data}
results=build/benchmarks
threads=
repeats=
quick=0
report_only=0
accuracy=0
mpi=1
python_path=
python=${PYTHON:-/usr/bin/python3}

usage() {
  sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'
  exit "${1:-2}"
}
while (($#)); do
  case $1 in
  --quick) quick=1 ;;
  --report) report_only=1 ;;
  --accuracy) accuracy=1 ;;
  --no-mpi) mpi=0 ;;
  --bench | --pslam | --mpi-bench | --data | --results | --threads | --repeats | --python-path)
    (($# >= 2)) || usage
    case $1 in
    --bench) bench=$2 ;;
    --pslam) pslam=$2 ;;
    --mpi-bench) mpi_bench=$2 ;;
    --data) data=$2 ;;
    --results) results=$2 ;;
    --threads) threads=$2 ;;
    --repeats) repeats=$2 ;;
    --python-path) python_path=$2 ;;
    esac
    shift
    ;;
  -h | --help) usage 0 ;;
  *)
    echo "benchmarks: unknown argument '$1'" >&2
    usage
    ;;
  esac
  shift
done

report() {
  "$python" scripts/benchmarks_report.py --results "$results" --docs docs
}
if ((report_only)); then
  report
  exit 0
fi

for exe in "$bench" "$pslam"; do
  [[ -x $exe ]] || {
    echo "benchmarks: $exe not found or not executable (build first, or --bench/--pslam)" >&2
    exit 2
  }
done
[[ -d $data ]] || {
  echo "benchmarks: data directory $data not found (--data)" >&2
  exit 2
}
"$python" -c 'import matplotlib' 2>/dev/null || {
  echo "benchmarks: $python has no matplotlib (Debian: apt-get install python3-matplotlib)" >&2
  exit 2
}

cores=$(nproc)
if [[ -z $threads ]]; then # 1, 2, 4, ... below nproc, and nproc
  threads=1
  for ((t = 2; t < cores; t *= 2)); do threads+=",$t"; done
  ((cores > 1)) && threads+=",$cores"
fi
max_threads=${threads##*,}
if [[ -z $repeats ]]; then
  repeats=3
  ((quick)) && repeats=1
fi
if [[ -z $python_path && -d build/python ]] && compgen -G 'build/python/pcl_parallel*.so' >/dev/null; then
  python_path=build/python
fi

if [[ -d $results && -n $(ls -A "$results") && ! -f $results/machine.txt ]]; then
  echo "benchmarks: $results holds files of something else; not replacing it (--results)" >&2
  exit 2
fi
rm -rf "$results"
mkdir -p "$results"
{
  echo "mode=$( ((quick)) && echo quick || echo full)"
  echo "date=$(date -u '+%Y-%m-%d %H:%M UTC')"
  echo "cores=$cores"
  echo "cpu=$(grep -m1 '^model name' /proc/cpuinfo | sed 's/^[^:]*: *//')"
  echo "memory_gib=$(awk '/^MemTotal/ { printf "%.0f", $2 / 1048576 }' /proc/meminfo)"
  echo "os=$(. /etc/os-release 2>/dev/null && echo "${PRETTY_NAME:-unknown}")"
  echo "kernel=$(uname -r)"
  echo "commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)$(git diff --quiet HEAD 2>/dev/null || echo ' (with local changes)')"
  echo "threads=$threads"
  echo "repeats=$repeats"
  echo "bench=$bench"
  echo "pslam=$pslam"
  echo "data=$data"
} >"$results/machine.txt"

started=$SECONDS
# job NAME COMMAND...: runs COMMAND, its stdout into NAME.txt, stderr into NAME.err, and
# NAME.meta: the command, times, load averages, exit status. A failing command is reported
# and the run goes on (its section then says so).
job() {
  local name=$1 start=$SECONDS rc=0
  shift
  printf '%-22s' "$name" >&2
  {
    echo "command=$*"
    echo "start=$(date -u '+%Y-%m-%d %H:%M:%S UTC')"
    echo "load_before=$(cut -d' ' -f1-3 /proc/loadavg)"
  } >"$results/$name.meta"
  "$@" >"$results/$name.txt" 2>"$results/$name.err" || rc=$?
  {
    echo "end=$(date -u '+%Y-%m-%d %H:%M:%S UTC')"
    echo "seconds=$((SECONDS - start))"
    echo "load_after=$(cut -d' ' -f1-3 /proc/loadavg)"
    echo "rc=$rc"
  } >>"$results/$name.meta"
  if ((rc)); then
    echo " FAILED (exit $rc, $((SECONDS - start)) s): see $results/$name.err" >&2
  else
    echo " $((SECONDS - start)) s" >&2
  fi
}

b=(--data "$data" --threads "$threads")
job kdtree "$bench" kdtree "${b[@]}" --repeats "$repeats"
job filters "$bench" filters "${b[@]}" --repeats "$repeats"
job icp "$bench" icp "${b[@]}" --repeats "$repeats"
job lum "$bench" lum "${b[@]}" --repeats "$repeats"
if ((quick)); then
  presets=(office riegl hannover)
else
  presets=(office riegl hannover kitti)
fi
for p in "${presets[@]}"; do
  job "pslam-$p" "$bench" "pslam-$p" "${b[@]}"
done
if ((quick)); then
  job sim "$bench" sim-office "${b[@]}"
else
  job pslam-kitti-cv "$bench" pslam-kitti-cv "${b[@]}"
  job sim "$bench" sim "${b[@]}"
  job memory "$bench" memory --data "$data" --threads "$max_threads"
  ((max_threads > 1)) && job contention "$bench" contention --data "$data" --threads "1,$max_threads" --repeats 1
fi
# The maps: pcl_pslam's own map.png (top view, trajectory in red) per preset.
for p in "${presets[@]}"; do
  job "map-$p" "$pslam" demo --preset "$p" --quiet -o "$results/map-$p"
done

# 2D (paper Sec. VII): the 2D presets against their truth, and the three CARMEN logs as they
# come, each against its recorded duration.
for p in office2d hannover2d; do
  job "map-$p" "$pslam" demo --preset "$p" --quiet -t "$max_threads" -o "$results/map-$p"
done
for log in intel fr079 mit-csail; do
  [[ -f $data/radish_2d/$log.clf.bz2 ]] &&
    job "log-$log" "$pslam" run "$data/radish_2d/$log.clf.bz2" --quiet -t "$max_threads" \
      -o "$results/log-$log"
done

# A hand-held 2 Hz LiDAR (issue 42): the handheld preset with its odometry and without.
job map-handheld "$pslam" demo --preset handheld --quiet -t "$max_threads" -o "$results/map-handheld"
job map-handheld-no-poses "$pslam" demo --preset handheld --no-poses --quiet -t "$max_threads" \
  -o "$results/map-handheld-no-poses"

# Loop closing against the paper's own front end (pICP scan to scan, which drifts).
for p in "${presets[@]}"; do
  job "s2s-$p" "$pslam" demo --preset "$p" --scan-to-scan --quiet -t "$max_threads" \
    -o "$results/s2s-$p"
done

# MPI: pLUM on the bunny over ranks, and (full run) the pipeline on hannover over ranks.
if ((mpi)) && [[ -x $mpi_bench ]] && command -v mpirun >/dev/null; then
  mpirun_=(mpirun --oversubscribe --bind-to none)
  ((EUID == 0)) && mpirun_+=(--allow-run-as-root)
  export PCL_PARALLEL_DATA_DIR=$data
  rows=("1 1" "1 $max_threads" "$max_threads 1")
  ((quick)) && rows=("1 1" "2 1")
  declare -A seen=()
  for row in "${rows[@]}"; do
    read -r r t <<<"$row"
    [[ -n ${seen[$r.$t]:-} ]] && continue
    seen[$r.$t]=1
    job "mpi-lum-${r}x$t" "${mpirun_[@]}" -np "$r" "$mpi_bench" "$t" 50
  done
  if ((!quick)); then
    export TMPDIR=$PWD/$results/tmp # the preset is written there once, then read by each run
    mkdir -p "$TMPDIR"
    job mpi-pslam-simulate "${mpirun_[@]}" -np 1 "$mpi_bench" pslam hannover 1 0
    job mpi-pslam-online-1x1 "${mpirun_[@]}" -np 1 "$mpi_bench" pslam hannover 1 0
    ((max_threads > 1)) && job "mpi-pslam-online-1x$max_threads" "${mpirun_[@]}" -np 1 "$mpi_bench" pslam hannover "$max_threads" 0
    ((max_threads > 1)) && job "mpi-pslam-segments-${max_threads}x1" "${mpirun_[@]}" -np "$max_threads" "$mpi_bench" pslam hannover 1 "$max_threads"
    rm -rf "$TMPDIR"
    unset TMPDIR
  fi
fi

if [[ -n $python_path ]]; then
  job python-gil env "PYTHONPATH=$python_path" "$python" apps/pcl_parallel_bench/python_gil.py
fi
if ((accuracy)); then
  job accuracy "$bench" accuracy --data "$data" --threads "$threads"
fi
echo "total=$((SECONDS - started))" >>"$results/machine.txt"
echo "benchmarks: $((SECONDS - started)) s of runs, results in $results/" >&2
report
