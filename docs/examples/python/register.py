#!/usr/bin/env python3
"""Registers two scans with pICP and prints the transform (source -> target).

  PYTHONPATH=build/python /usr/bin/python3 docs/examples/python/register.py \
      ../shared/data/pcl_test/bun0.pcd ../shared/data/pcl_test/bun4.pcd --max-distance 0.05
"""
import argparse

import numpy as np

import pcl_parallel as pp


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("source")
    ap.add_argument("target")
    ap.add_argument("--max-distance", type=float, default=float("inf"))
    ap.add_argument("--iterations", type=int, default=50)
    ap.add_argument("--point-to-plane", action="store_true")
    args = ap.parse_args()
    source, target = pp.read_scan(args.source), pp.read_scan(args.target)
    r = pp.icp(source, target, max_distance=args.max_distance, iterations=args.iterations,
               metric="point_to_plane" if args.point_to_plane else "point_to_point")
    print(f"{len(source)} -> {len(target)} points: converged={r.converged} after "
          f"{r.iterations} iterations, fitness {r.fitness:.6g}")
    print(np.array2string(r.transformation, precision=4, suppress_small=True))


if __name__ == "__main__":
    main()
