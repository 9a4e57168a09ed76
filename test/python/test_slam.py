# Pipeline: the office preset mapped scan by scan gives pcl_pslam run's poses bit for bit.
import os
import subprocess

import numpy as np
import pytest

import pcl_parallel as pp


@pytest.fixture(scope="module")
def office(tmp_path_factory, pslam):
    """The office preset simulated by the module and mapped by pcl_pslam run."""
    base = tmp_path_factory.mktemp("office")
    summary = pp.simulate("office", base / "scans")
    assert summary["scans"] == 11 and not summary["moving"]
    subprocess.run([pslam, "run", str(base / "scans"), "--out", str(base / "run"), "-q",
                    "--no-picture"], check=True)
    return base


def _map(directory, opening=None, **parameters):
    d = pp.ScanDirectory(directory, **(opening or {}))
    pipeline = pp.Pipeline(guess={"up": d.up}, planar=d.planar, **parameters)
    for k in range(len(d)):
        stamp = d.stamps[k] if d.stamps is not None else None
        pose = pipeline.add_scan(d.read(k), d.odometry[k], stamp)
        assert pose.shape == (4, 4)
    pipeline.finish()
    return pipeline


def test_pipeline_matches_pslam_run(office):
    pipeline = _map(office / "scans")
    assert np.array_equal(pipeline.poses, pp.read_poses(office / "run" / "poses.txt"))
    assert np.array_equal(pipeline.front_end_poses,
                          pp.read_poses(office / "run" / "poses_icp.txt"))
    assert any(loop for _, _, loop in pipeline.links)  # the office loop closed
    assert len(pipeline) == 11
    assert pipeline.resolved_parameters["reduction"]["voxel_size"] > 0
    cloud = pipeline.map(0.1)
    assert cloud.ndim == 2 and cloud.shape[1] == 3 and len(cloud) > 1000
    # Where the scanner came back: the figures of pcl_pslam run's report, exactly.
    import json
    report = json.loads((office / "run" / "report.json").read_text())["consistency"]
    keys = ("revisits", "mean_conflicts", "conflicting")
    assert pipeline.consistency() == {k: report[k] for k in keys}
    assert pipeline.consistency(front_end=True) == {k: report["front_end"][k] for k in keys}
    assert report["revisits"] > 0


def test_2d_scans_match_pslam_run(pslam, tmp_path):
    # A directory of 2D scans (a horizontal scanner's, in their x-y plane) is mapped in the
    # plane by both.
    pp.simulate("office2d", tmp_path / "scans")
    assert pp.ScanDirectory(tmp_path / "scans").planar
    subprocess.run([pslam, "run", str(tmp_path / "scans"), "--out", str(tmp_path / "run"),
                    "-q", "--no-picture"], check=True)
    pipeline = _map(tmp_path / "scans")  # with the odometry.txt `simulate` wrote
    assert np.array_equal(pipeline.poses, pp.read_poses(tmp_path / "run" / "poses.txt"))
    # In the plane: the scanner's height and its upright axis stay the odometry's.
    assert np.allclose(pipeline.poses[:, 2, 3], pipeline.poses[0, 2, 3], rtol=0, atol=1e-12)
    assert np.all(pipeline.poses[:, 2, 2] == 1.0)


def test_2d_log_matches_pslam_run(data_dir, pslam, tmp_path):
    # A CARMEN log: its odometry and time stamps, the scans its motion filter keeps.
    log = os.path.join(data_dir, "radish_2d", "intel.clf.bz2")
    if not os.path.isfile(log):
        pytest.skip(f"{log} absent")
    subprocess.run([pslam, "run", log, "-e", "299", "--out", str(tmp_path / "run"), "-q",
                    "--no-picture"], check=True)
    pipeline = _map(log, {"last": 299})  # -e: the log's scans, of which the filter keeps some
    assert len(pipeline) > 20
    assert np.array_equal(pipeline.poses, pp.read_poses(tmp_path / "run" / "poses.txt"))


def test_simulate_matches_pslam_simulate(office, pslam, tmp_path):
    subprocess.run([pslam, "simulate", "--preset", "office", str(tmp_path / "s")],
                   check=True, stdout=subprocess.DEVNULL)
    for name in ("scan000.3d", "scan010.pose", "ground_truth.txt"):
        assert (tmp_path / "s" / name).read_bytes() == (office / "scans" / name).read_bytes()


def test_evaluate_matches_pslam_evaluate(office, pslam):
    est, truth = office / "run" / "poses.txt", office / "scans" / "ground_truth.txt"
    printed = subprocess.run([pslam, "evaluate", str(est), str(truth), "--json"], check=True,
                             capture_output=True, text=True).stdout
    import json
    assert pp.evaluate(est, truth) == json.loads(printed)
    arrays = pp.evaluate(pp.read_poses(est), pp.read_poses(truth))
    assert arrays["ate"] == json.loads(printed)["ate"]


def test_parameters_named_as_in_cpp():
    d = pp.default_parameters()
    assert d["matcher"]["max_iterations"] == 50 and d["matcher"]["target"] == "local_map"
    assert d["loops"]["min_separation"] == 5 and d["reduction"]["voxel_size"] == 0.0
    p = pp.Pipeline(matcher={"max_iterations": 20}, loops={"enabled": False}, threads=1)
    assert p.parameters["matcher"]["max_iterations"] == 20
    assert p.parameters["loops"]["enabled"] is False and p.resolved_parameters is None
    assert len(p) == 0 and p.poses.shape == (0, 4, 4) and p.map().shape == (0, 3)
    assert p.consistency() == {"revisits": 0, "mean_conflicts": 0.0, "conflicting": 0}
    assert d["planar"] is False and pp.Pipeline(planar=True).parameters["planar"] is True


@pytest.mark.parametrize("kwargs, word", [
    ({"matcher": {"max_iterationz": 3}}, "matcher.max_iterationz"),
    ({"matchers": {}}, "matchers"),
    ({"matcher": {"max_iterations": 2.5}}, "matcher.max_iterations"),
    ({"matcher": {"target": "map"}}, "matcher.target"),
    ({"reduction": {"voxel_size": -1.0}}, "reduction.voxel_size"),
    ({"reduction": {"voxel_size": float("nan")}}, "reduction.voxel_size"),
    ({"loops": {"enabled": 1}}, "loops.enabled"),
    ({"guess": {"up": (0, 0)}}, "guess.up"),
    ({"loops": 3}, "loops"),
    ({"threads": 2.0}, "threads"),
    ({"median_range": -1.0}, "median_range"),
    ({"planar": 1}, "planar"),
])
def test_bad_parameters_raise_value_error(kwargs, word):
    with pytest.raises(ValueError, match=word.replace(".", r"\.")):
        pp.Pipeline(**kwargs)


def test_bad_scans_raise_value_error():
    p = pp.Pipeline()
    pts = np.random.default_rng(0).uniform(1, 5, (100, 3))
    with pytest.raises(ValueError, match="points"):
        p.add_scan(np.zeros((0, 3)))
    with pytest.raises(ValueError, match="points"):
        p.add_scan(pts[:, :2])
    with pytest.raises(ValueError, match="odometry"):
        p.add_scan(pts, np.eye(3))
    with pytest.raises(ValueError, match="odometry.*rigid"):
        p.add_scan(pts, np.ones((4, 4)))
    with pytest.raises(ValueError, match="point_times"):
        p.add_scan(pts, point_times=np.zeros(3))
    with pytest.raises(ValueError, match="stamp"):
        p.add_scan(pts, stamp=float("nan"))
    assert len(p) == 0
