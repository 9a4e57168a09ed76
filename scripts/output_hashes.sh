#!/usr/bin/env bash
# SHA-256 of pcl_pslam's poses.txt, poses_icp.txt and map.pcd for a fixed list of runs: a
# refactoring (or a change of the threading) that must not change one output byte prints
# the same lines before and after.
#
#   scripts/output_hashes.sh [PCL_PSLAM] [WORK_DIR]
#
# PCL_PSLAM defaults to build/apps/pcl_pslam, WORK_DIR to a fresh temporary directory
# (kept, so the outputs can be compared file by file). Runs on 2 threads unless THREADS is
# set; the data comes from ../shared/data (DATA to override). Runs whose data is absent, and
# the MPI run where mpirun is missing, print "skipped". About 5-10 minutes on 2 cores.
# scripts/output_hashes.expected holds the lines of the commit it names (Debian 12, GCC 12):
#   scripts/output_hashes.sh | diff <(grep -v "^#" scripts/output_hashes.expected) -
set -euo pipefail
cd "$(dirname "$0")/.."
app=$(realpath "${1:-build/apps/pcl_pslam}")
work=${2:-$(mktemp -d /tmp/pcl_parallel_hashes.XXXXXX)}
data=${DATA:-$(realpath ../shared/data 2>/dev/null || echo ../shared/data)}
threads=${THREADS:-2}
mkdir -p "$work"
echo "# $app, -t $threads, outputs under $work" >&2

# The simulated presets, written once per work directory.
for p in office hannover riegl kitti; do
  [[ -d "$work/sim_$p" ]] || "$app" simulate -p "$p" "$work/sim_$p" > /dev/null
done

hashes() { # name, then pcl_pslam's arguments after `run`
  local name=$1 out="$work/out_$1"
  shift
  rm -rf "$out"
  if ! "$@" -o "$out" -t "$threads" --quiet > "$work/log_$name.txt" 2>&1; then
    echo "$name FAILED (see $work/log_$name.txt)"
    return
  fi
  for f in poses.txt poses_icp.txt map.pcd; do
    if [[ -f "$out/$f" ]]; then
      echo "$name $f $(sha256sum < "$out/$f" | cut -c1-16)"
    elif [[ $f == map.pcd && -f "$out/map_rank0.pcd" ]]; then # under mpirun: a tile per rank
      echo "$name map_rank*.pcd $(cat "$out"/map_rank*.pcd | sha256sum | cut -c1-16)"
    else
      echo "$name $f absent"
    fi
  done
}

for p in office hannover riegl; do
  hashes "$p" "$app" run "$work/sim_$p"
  hashes "$p-no-poses" "$app" run "$work/sim_$p" --no-poses
done
hashes kitti "$app" run "$work/sim_kitti" --deskew
hashes kitti-no-poses "$app" run "$work/sim_kitti" --deskew --no-poses
hashes hannover-scan-to-scan "$app" run "$work/sim_hannover" --scan-to-scan
hashes office-scan-to-scan-no-poses "$app" run "$work/sim_office" --scan-to-scan --no-poses

if [[ -d "$data/fastlio_quick_shack" ]]; then
  hashes fastlio "$app" run "$data/fastlio_quick_shack/bin" \
    --poses "$data/fastlio_quick_shack/odom_poses.txt"
  hashes fastlio-no-poses "$app" run "$data/fastlio_quick_shack/bin" --no-poses
else
  echo "fastlio skipped (no $data/fastlio_quick_shack)"
fi
if [[ -d "$data/mulran_riverside02_keyframes" ]]; then
  hashes mulran "$app" run "$data/mulran_riverside02_keyframes/bin" --no-poses
else
  echo "mulran skipped (no $data/mulran_riverside02_keyframes)"
fi
if [[ -d "$data/3dtk_dat" ]]; then # README's 3DTK line (the paper's slam6D settings)
  hashes 3dtk "$app" run -s 0 -e 65 -r 10 -i 100 -d 75 -D 250 -I 50 --cldist 750 -f uos \
    -m 3000 -M 50 "$data/3dtk_dat"
else
  echo "3dtk skipped (no $data/3dtk_dat)"
fi
if command -v mpirun > /dev/null; then
  mpi=(mpirun -np 2 --bind-to none --oversubscribe)
  [[ $(id -u) == 0 ]] && mpi+=(--allow-run-as-root)
  hashes office-mpi2 "${mpi[@]}" "$app" run "$work/sim_office" --segment-size 6
else
  echo "office-mpi2 skipped (no mpirun)"
fi
