# read_scan, read_poses / write_poses, ScanDirectory, evaluate: files in, arrays out;
# files that cannot be read raise OSError with the C++ message.
import os

import numpy as np
import pytest

import pcl_parallel as pp


def test_read_scan_formats(dtk_dir, tmp_path):
    path = os.path.join(dtk_dir, "scan000.3d")
    points = pp.read_scan(path)
    assert points.dtype == np.float32 and points.shape[1] == 3 and len(points) > 60000
    assert np.array_equal(pp.read_scan(path, "uos"), points)
    near = pp.read_scan(path, max_range=1000.0)
    assert 0 < len(near) < len(points)
    assert (np.linalg.norm(near.astype(np.float64), axis=1) <= 1000.0).all()
    points.astype("<f4").tofile(tmp_path / "scan.dat")  # no intensity: not a .bin
    with pytest.raises(ValueError, match="format"):
        pp.read_scan(path, "nosuch")
    scan, times = pp.read_scan(path, point_times=True)
    assert times is None and np.array_equal(scan, points)


def test_scan_directory_reads_as_pslam(dtk_dir):
    d = pp.ScanDirectory(dtk_dir)
    assert len(d) == 3 and d.format == "3d" and d.scale == 0.01 and d.up == (0.0, 1.0, 0.0)
    assert d.odometry.shape == (3, 4, 4) and d.stamps is None
    metres = d.read(0)
    assert np.allclose(metres, pp.read_scan(d.files[0]) * 0.01, rtol=1e-6)
    with pytest.raises(IndexError):
        d.read(3)


def test_scan_directory_reads_a_2d_log(tmp_path):
    # Three 180-beam FLASER scans of a wall 2 m ahead, the robot 0.5 m further each time
    # (the log's motion filter keeps a scan per 0.2 m); beam i at -90 + i degrees.
    lines = []
    for k in range(3):
        x = 0.5 * k
        ranges = " ".join("2.0" if i == 90 else "81.91" for i in range(180))
        lines.append(f"FLASER 180 {ranges} {x} 0 0 {x} 0 0 {10.0 + k} host {k}")
    (tmp_path / "wall.clf").write_text("\n".join(lines) + "\n")
    d = pp.ScanDirectory(tmp_path / "wall.clf")
    assert len(d) == 3 and d.format == "clf" and d.up == (0.0, 0.0, 1.0)
    assert np.array_equal(d.stamps, [10.0, 11.0, 12.0])
    assert np.allclose(d.odometry[:, 0, 3], [0.0, 0.5, 1.0])
    assert np.allclose(d.read(1), [[2.0, 0.0, 0.0]])  # the one return; "no return" dropped


def test_poses_round_trip(tmp_path):
    rng = np.random.default_rng(2)
    poses = np.stack([np.eye(4)] * 5)
    poses[:, :3, 3] = rng.normal(size=(5, 3)) * 1e3
    a = 0.3
    poses[2, :2, :2] = [[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]
    pp.write_poses(tmp_path / "k.txt", poses)
    assert np.array_equal(pp.read_poses(tmp_path / "k.txt"), poses)
    stamps = np.arange(5) * 0.1 + 1e9
    pp.write_poses(str(tmp_path / "t.txt"), poses, format="tum", timestamps=stamps)
    back, t = pp.read_poses(tmp_path / "t.txt", with_timestamps=True)
    assert np.allclose(back, poses, atol=1e-9) and np.array_equal(t, stamps)
    with pytest.raises(ValueError, match="format"):
        pp.write_poses(tmp_path / "x.txt", poses, format="g2o")
    with pytest.raises(ValueError, match="poses"):
        pp.write_poses(tmp_path / "x.txt", poses[:, :3])


def test_files_that_cannot_be_read_raise_os_error(tmp_path):
    with pytest.raises(OSError, match="nosuch.3d"):
        pp.read_scan(tmp_path / "nosuch.3d")
    with pytest.raises(OSError, match="nosuch.txt"):
        pp.read_poses(tmp_path / "nosuch.txt")
    (tmp_path / "bad.txt").write_text("1 2 3\n")
    with pytest.raises(OSError, match="bad.txt"):
        pp.read_poses(tmp_path / "bad.txt")
    (tmp_path / "bad.xyz").write_text("not a point\n")
    with pytest.raises(OSError, match="bad.xyz"):
        pp.read_scan(tmp_path / "bad.xyz")
    with pytest.raises(OSError):
        pp.ScanDirectory(tmp_path / "nosuch")
    with pytest.raises(OSError):
        pp.write_poses(tmp_path / "nosuch" / "p.txt", np.eye(4)[None])
    with pytest.raises(ValueError, match="path"):
        pp.read_scan(3)


def test_evaluate_arrays():
    truth = np.stack([np.eye(4)] * 20)
    truth[:, 0, 3] = np.arange(20.0)
    truth[:, 2, 3] = np.sin(np.arange(20.0))  # not on one line: SE(3) alignment defined
    estimate = truth.copy()
    estimate[:, 1, 3] = 0.1
    e = pp.evaluate(estimate, truth, align="none")
    assert e["poses"] == 20
    assert e["ate"]["translation_m"]["rmse"] == pytest.approx(0.1)
    assert pp.evaluate(estimate, truth)["ate"]["translation_m"]["rmse"] < 1e-9  # se3
    with pytest.raises(ValueError, match="truth"):
        pp.evaluate(estimate, truth[:, :3])
    with pytest.raises(ValueError):
        pp.evaluate(estimate, truth, align="sim4")
    with pytest.raises(ValueError, match="3 poses"):
        pp.evaluate(estimate[:3], truth)
