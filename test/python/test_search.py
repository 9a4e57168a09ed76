# KdTree.nearest(): the same answers as KdTreeIndex (reference.cpp) for every array layout.
import os

import numpy as np
import pytest

import pcl_parallel as pp
from conftest import layouts


@pytest.mark.parametrize("k, max_distance", [(1, float("inf")), (1, 20.0), (3, 30.0)])
def test_matches_cpp(dtk_dir, reference, tmp_path, k, max_distance):
    cloud_file = os.path.join(dtk_dir, "scan000.3d")
    query_file = os.path.join(dtk_dir, "scan001.3d")
    out = tmp_path / "knn.bin"
    reference("knn", cloud_file, query_file, out, k, max_distance, 0)
    queries = pp.read_scan(query_file)
    raw = np.fromfile(out, dtype="<i8", count=len(queries) * k)
    dist = np.fromfile(out, dtype="<f8", offset=raw.nbytes)
    idx, d = pp.KdTree(pp.read_scan(cloud_file)).nearest(queries, k, max_distance=max_distance)
    assert idx.shape == ((len(queries),) if k == 1 else (len(queries), k))
    assert np.array_equal(idx.ravel(), raw) and np.array_equal(d.ravel(), dist)
    assert (idx >= 0).any() and (max_distance == float("inf") or (idx < 0).any())


def test_layouts_threads_and_brute_force_agree():
    rng = np.random.default_rng(3)
    points = rng.uniform(-1, 1, (2000, 3)).astype(np.float32)
    queries = rng.uniform(-1, 1, (500, 3)).astype(np.float32)
    first = pp.KdTree(points).nearest(queries, 4)
    for name, p in layouts(points).items():
        for threads in (1, 2):
            tree = pp.KdTree(p, threads=threads)
            assert len(tree) == len(points)
            got = tree.nearest(layouts(queries)[name], 4, threads=threads)
            assert np.array_equal(got[0], first[0]) and np.array_equal(got[1], first[1]), name
    swapped = pp.KdTree(points.astype(">f8")).nearest(queries.astype(">f4"), 4)  # big-endian
    assert np.array_equal(swapped[0], first[0]) and np.array_equal(swapped[1], first[1])
    d2 = ((queries[:, None, :].astype(np.float64) - points[None]) ** 2).sum(-1)
    order = np.argsort(d2, axis=1)[:, :4]
    assert np.array_equal(first[0], order)
    assert np.allclose(first[1], np.sqrt(np.take_along_axis(d2, order, 1)), rtol=1e-5)


def test_max_distance_is_inclusive_and_missing_is_minus_one():
    tree = pp.KdTree(np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]))
    idx, d = tree.nearest(np.array([[1.0, 0.0, 0.0], [10.0, 0.0, 0.0]]), 2, max_distance=1.0)
    assert idx.tolist() == [[0, 1], [-1, -1]]
    assert d[0].tolist() == [1.0, 1.0] and np.isinf(d[1]).all()


@pytest.mark.parametrize("bad, word", [
    (np.zeros((5, 2)), "shape"),
    (np.zeros((5, 3), dtype=np.int64), "dtype"),
    (np.zeros((0, 3)), "no points"),
    (np.array([[np.nan, 0.0, 0.0]]), "not finite"),
])
def test_bad_input_raises_value_error(bad, word):
    with pytest.raises(ValueError, match="points.*" + word):
        pp.KdTree(bad)
    tree = pp.KdTree(np.eye(3))
    with pytest.raises(ValueError, match="queries.*" + word):
        tree.nearest(bad)
    with pytest.raises(ValueError, match="k"):
        tree.nearest(np.eye(3), 0)
    with pytest.raises(ValueError, match="max_distance"):
        tree.nearest(np.eye(3), max_distance=-1.0)
