#!/usr/bin/env python3
"""Whether pcl_parallel's calls release the GIL (docs/benchmarks.md, "Python").

  PYTHONPATH=build/python /usr/bin/python3 apps/pcl_parallel_bench/python_gil.py

Counts the Python-loop ticks the main thread makes while icp() runs on another thread
(released GIL: millions; held: about none), then times two single-threaded ICPs in turn
against the same two on two Python threads (released: about half the time on 2 cores).
"""
import statistics
import threading
import time

import numpy as np

import pcl_parallel as pp

POINTS = np.random.default_rng(0).uniform(-5.0, 5.0, (200000, 3))


def one_icp():
    pp.icp(POINTS + 0.01, POINTS, max_distance=0.5, threads=1)


def ticks_during_icp():
    worker = threading.Thread(target=one_icp)
    ticks = 0
    worker.start()
    while worker.is_alive():
        ticks += 1
    return ticks


def seconds(run):
    start = time.perf_counter()
    run()
    return time.perf_counter() - start


def two_on_threads():
    workers = [threading.Thread(target=one_icp) for _ in range(2)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()


def main(repeats=5):
    ticks = ticks_during_icp()
    in_turn = statistics.median(seconds(lambda: (one_icp(), one_icp())) for _ in range(repeats))
    threaded = statistics.median(seconds(two_on_threads) for _ in range(repeats))
    print(f"{ticks} main-thread ticks during one icp(); 2 x icp(threads=1), median of "
          f"{repeats}: in turn {in_turn:.3f} s, on 2 Python threads {threaded:.3f} s "
          f"({in_turn / threaded:.2f}x)")


if __name__ == "__main__":
    main()
