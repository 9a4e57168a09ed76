# icp(): the same numbers as ParallelIterativeClosestPoint on the 3DTK pair (reference.cpp),
# for every array layout; bad input raises ValueError naming the argument.
import os

import numpy as np
import pytest

import pcl_parallel as pp
from conftest import layouts

RANGE = (50.0, 3000.0)  # cm: near-range junk and the 3276.7 cm no-returns out


def _pair(dtk_dir):
    src = os.path.join(dtk_dir, "scan001.3d")
    tgt = os.path.join(dtk_dir, "scan000.3d")
    d = pp.ScanDirectory(dtk_dir)
    init = np.linalg.inv(d.odometry[0]) @ d.odometry[1]
    init[:3, 3] *= 100.0  # the odometry is in metres, the files in cm
    return src, tgt, init


@pytest.mark.parametrize("metric", ["point_to_point", "point_to_plane"])
def test_matches_cpp(dtk_dir, reference, tmp_path, metric):
    src, tgt, init = _pair(dtk_dir)
    pp.write_poses(tmp_path / "init.txt", init[None])
    out = tmp_path / "icp.bin"
    reference("icp", src, tgt, tmp_path / "init.txt", out, *RANGE, 25.0, 50, metric, 0)
    ref = np.fromfile(out, dtype="<f8")
    s = pp.read_scan(src, min_range=RANGE[0], max_range=RANGE[1])
    t = pp.read_scan(tgt, min_range=RANGE[0], max_range=RANGE[1])
    r = pp.icp(s, t, init, max_distance=25.0, iterations=50, metric=metric)
    assert np.array_equal(r.transformation.ravel(), ref[:16])
    assert (r.converged, r.fitness, r.iterations) == (bool(ref[16]), ref[17], int(ref[18]))
    assert r.iterations > 1


def test_layouts_and_threads_agree(dtk_dir):
    src, tgt, init = _pair(dtk_dir)
    s = pp.read_scan(src, min_range=RANGE[0], max_range=RANGE[1])[::7]
    t = pp.read_scan(tgt, min_range=RANGE[0], max_range=RANGE[1])[::5]
    first = pp.icp(s, t, init, max_distance=25.0)
    for name, a in layouts(s).items():
        for threads in (1, 2):
            r = pp.icp(a, layouts(t)[name], init, max_distance=25.0, threads=threads)
            assert np.array_equal(r.transformation, first.transformation), name
            assert r.fitness == first.fitness and r.iterations == first.iterations


def test_recovers_a_known_motion():
    rng = np.random.default_rng(1)
    target = rng.uniform(-5, 5, (3000, 3))
    a = 0.05
    motion = np.eye(4)
    motion[:2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    motion[:3, 3] = [0.1, -0.05, 0.02]
    source = (target - motion[:3, 3]) @ motion[:3, :3]  # motion @ source = target
    r = pp.icp(source, target, max_distance=1.0, robust=("huber", 0.5))
    assert r.converged
    assert np.allclose(r.transformation, motion, atol=1e-4)


@pytest.mark.parametrize("bad, word", [
    (np.zeros((10, 2)), "shape"),
    (np.zeros((10, 3, 1)), "shape"),
    (np.zeros(3), "shape"),
    (np.zeros((10, 3), dtype=np.int32), "dtype"),
    (np.zeros((0, 3)), "no points"),
    (np.array([[0.0, np.nan, 1.0]] * 5), "not finite"),
    (np.array([[0.0, np.inf, 1.0]] * 5), "not finite"),
    (None, "None"),
    ("points", "dtype"),
])
def test_bad_points_raise_value_error(bad, word):
    good = np.random.default_rng(0).uniform(size=(20, 3))
    with pytest.raises(ValueError, match="source.*" + word):
        pp.icp(bad, good)
    with pytest.raises(ValueError, match="target.*" + word):
        pp.icp(good, bad)


@pytest.mark.parametrize("kwargs, word", [
    ({"init": np.eye(3)}, "init"),
    ({"init": np.full((4, 4), np.nan)}, "init"),
    ({"max_distance": -1.0}, "max_distance"),
    ({"max_distance": float("nan")}, "max_distance"),
    ({"iterations": 0}, "iterations"),
    ({"metric": "plane"}, "metric"),
    ({"robust": ("cauchy", 1.0)}, "robust"),
    ({"robust": ("huber", -1.0)}, "robust"),
    ({"threads": -1}, "threads"),
    ({"epsilon": -1.0}, "epsilon"),
])
def test_bad_arguments_raise_value_error(kwargs, word):
    pts = np.random.default_rng(0).uniform(size=(20, 3))
    with pytest.raises(ValueError, match=word):
        pp.icp(pts, pts, **kwargs)


def test_planar_stays_in_the_plane():
    # A 2D scan (z = 0): the outline of a 4 x 3 m room with a pillar, moved by a planar step.
    rng = np.random.default_rng(3)
    walls = [((-2, -1.5), (2, -1.5)), ((2, -1.5), (2, 1.5)), ((2, 1.5), (-2, 1.5)),
             ((-2, 1.5), (-2, -1.5)), ((0, 0), (0.5, 0)), ((0.5, 0), (0.5, 0.5))]
    pts = []
    for (ax, ay), (bx, by) in walls:
        for s in np.arange(0.0, 1.0, 0.005):
            pts.append((ax + s * (bx - ax), ay + s * (by - ay), 0.0))
    target = np.array(pts) + np.c_[rng.normal(0, 0.002, (len(pts), 2)), np.zeros(len(pts))]
    yaw = np.radians(4.0)
    step = np.eye(4)
    step[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
    step[:2, 3] = (0.1, -0.05)
    source = (target - step[:3, 3]) @ step[:3, :3]  # step^-1 applied to the target
    r = pp.icp(source, target, max_distance=0.5, iterations=100, planar=True)
    t = r.transformation
    assert r.converged
    assert (t[2, :] == [0.0, 0.0, 1.0, 0.0]).all() and (t[:2, 2] == 0.0).all()
    assert np.allclose(t, step, atol=1e-3)
