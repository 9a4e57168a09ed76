# lum(): the same poses as ParallelLUM in pLUM mode (reference.cpp) on the 3DTK scans.
import numpy as np
import pytest

import pcl_parallel as pp
from conftest import layouts

OPTIONS = dict(max_distance=0.5, final_distance=0.1, iterations=5, epsilon=1e-4)


def _scans(dtk_dir):
    d = pp.ScanDirectory(dtk_dir, min_range=50.0, max_range=3000.0)
    return [d.read(k) for k in range(len(d))], d.odometry


def test_matches_cpp(dtk_dir, reference, tmp_path):
    scans, poses = _scans(dtk_dir)
    links = np.array([[0, 1], [1, 2], [0, 2]])
    pp.write_poses(tmp_path / "poses.txt", poses)
    np.savetxt(tmp_path / "links.txt", links, fmt="%d")
    out = tmp_path / "lum.bin"
    o = OPTIONS
    reference("lum", dtk_dir, tmp_path / "poses.txt", tmp_path / "links.txt", out, 50.0,
              3000.0, o["max_distance"], o["final_distance"], o["iterations"], o["epsilon"], 0)
    got = pp.lum(scans, poses, links, **OPTIONS)
    assert got.shape == (3, 4, 4)
    assert np.array_equal(got.ravel(), np.fromfile(out, dtype="<f8"))
    assert not np.array_equal(got, poses)  # it moved them


def test_default_links_layouts_and_threads(dtk_dir):
    scans, poses = _scans(dtk_dir)
    scans = [s[::4] for s in scans]
    explicit = pp.lum(scans, poses, [[0, 1], [1, 2]], **OPTIONS)
    assert np.array_equal(pp.lum_links(poses, 5.0, 5, 5.0), [[0, 1], [1, 2]])
    assert np.array_equal(pp.lum(scans, poses, **OPTIONS), explicit)
    for name in ("float32", "fortran", "sliced"):
        got = pp.lum([layouts(s)[name] for s in scans], poses, [[0, 1], [1, 2]], threads=1,
                     **OPTIONS)
        assert np.array_equal(got, explicit), name


def test_bad_input_raises_value_error():
    pts = np.random.default_rng(0).uniform(size=(50, 3))
    two = np.stack([np.eye(4)] * 2)
    with pytest.raises(ValueError, match="poses"):
        pp.lum([pts, pts], np.eye(4))
    with pytest.raises(ValueError, match="poses"):
        pp.lum([pts, pts, pts], two)
    with pytest.raises(ValueError, match=r"scans\[1\].*not finite"):
        pp.lum([pts, pts * np.nan], two)
    with pytest.raises(ValueError, match="links"):
        pp.lum([pts, pts], two, [[0, 5]])
    with pytest.raises(ValueError, match="links"):
        pp.lum([pts, pts], two, [[0.0, 1.0]])
    with pytest.raises(ValueError, match="final_distance"):
        pp.lum([pts, pts], two, max_distance=0.1, final_distance=0.2)
