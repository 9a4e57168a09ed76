#!/usr/bin/env python3
"""Maps a directory of KITTI .bin scans with pcl_parallel.Pipeline, KISS-ICP style: scans
one at a time with progress, then the trajectory's top view and the map's (trajectory.png).

  PYTHONPATH=build/python /usr/bin/python3 docs/examples/python/kitti_map.py \
      ../shared/data/kitti_mini_dev/00/velodyne --deskew
"""
import argparse
import glob
import os
import sys
import time

import matplotlib

matplotlib.use("Agg")  # a file, no display needed
import matplotlib.pyplot as plt  # noqa: E402

import pcl_parallel as pp  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("directory", help="a directory of KITTI .bin scans")
    ap.add_argument("--deskew", action="store_true", help="raw sweeps: undo the motion")
    ap.add_argument("--max-range", type=float, default=100.0, help="metres")
    ap.add_argument("--out", default="trajectory.png")
    args = ap.parse_args()
    files = sorted(glob.glob(os.path.join(args.directory, "*.bin")))
    if not files:
        sys.exit(f"no .bin scans in {args.directory}")
    pipeline = pp.Pipeline(reduction={"max_range": args.max_range},
                           deskew={"enabled": args.deskew})
    start = time.monotonic()
    for k, path in enumerate(files):
        pose = pipeline.add_scan(pp.read_scan(path, max_range=args.max_range))
        rate = (k + 1) / (time.monotonic() - start)
        where = "" if pose is None else " at (%.1f, %.1f, %.1f) m" % tuple(pose[:3, 3])
        print(f"\r[{k + 1}/{len(files)}] {rate:.1f} scans/s{where}   ", end="", flush=True)
    pipeline.finish()
    print(f"\n{len(pipeline)} scans, {sum(loop for *_, loop in pipeline.links)} loop links")
    c = pipeline.consistency()  # where the car came back: doubled walls show here
    print(f"{c['conflicting']} of {c['revisits']} revisits disagree")
    poses = pipeline.poses
    cloud = pipeline.map(0.5)
    fig, ax = plt.subplots(figsize=(8, 8))
    ax.scatter(cloud[:, 0], cloud[:, 1], s=0.2, c="0.6", linewidths=0)
    ax.plot(poses[:, 0, 3], poses[:, 1, 3], "r-", label="pLUM")
    front = pipeline.front_end_poses
    ax.plot(front[:, 0, 3], front[:, 1, 3], "b--", lw=0.8, label="front end")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend()
    fig.savefig(args.out, dpi=120, bbox_inches="tight")
    poses_file = os.path.splitext(args.out)[0] + "_poses.txt"
    pp.write_poses(poses_file, poses)  # KITTI lines: pcl_pslam evaluate takes them
    print(f"wrote {args.out} and {poses_file}")


if __name__ == "__main__":
    main()
