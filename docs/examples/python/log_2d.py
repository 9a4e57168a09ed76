#!/usr/bin/env python3
"""Maps a 2D laser log (CARMEN .clf or .clf.bz2) with pcl_parallel.Pipeline in the plane, as
`pcl_pslam run LOG` does: the log's odometry and time stamps, pLUM after each loop; then
the trajectory over the map's points (log_2d.png) and TUM poses with the log's stamps.

  PYTHONPATH=build/python /usr/bin/python3 docs/examples/python/log_2d.py \\
      ../shared/data/radish_2d/intel.clf.bz2
"""
import argparse
import os

import matplotlib

matplotlib.use("Agg")  # a file, no display needed
import matplotlib.pyplot as plt  # noqa: E402

import pcl_parallel as pp  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("log", help="a CARMEN log: FLASER / ROBOTLASER1 scans, ODOM")
    ap.add_argument("--out", default="log_2d.png")
    args = ap.parse_args()
    log = pp.ScanDirectory(args.log)  # the scans the motion filter keeps (0.2 m or 10 deg)
    pipeline = pp.Pipeline(planar=log.planar)  # x, y and heading alone (paper Sec. VII)
    for k in range(len(log)):
        pipeline.add_scan(log.read(k), log.odometry[k], log.stamps[k])
        print(f"\r[{k + 1}/{len(log)}]", end="", flush=True)
    pipeline.finish()
    c = pipeline.consistency()  # where the robot came back: doubled walls show here
    print(f"\n{c['conflicting']} of {c['revisits']} revisits disagree")
    poses = pipeline.poses
    cloud = pipeline.map(0.05)
    fig, ax = plt.subplots(figsize=(8, 8))
    ax.scatter(cloud[:, 0], cloud[:, 1], s=0.2, c="k", linewidths=0)
    ax.plot(poses[:, 0, 3], poses[:, 1, 3], "r-", lw=0.6)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    fig.savefig(args.out, dpi=120, bbox_inches="tight")
    poses_file = os.path.splitext(args.out)[0] + "_tum.txt"
    pp.write_poses(poses_file, poses, format="tum", timestamps=log.stamps)
    print(f"wrote {args.out} and {poses_file}")


if __name__ == "__main__":
    main()
