# The installed module imports in a fresh interpreter that sees only the install prefix.
import os
import subprocess
import sys

import pytest


def test_installed_module_imports(tmp_path):
    cmake, build = os.environ.get("CMAKE_COMMAND"), os.environ.get("PCL_PARALLEL_BUILD_DIR")
    site = os.environ.get("PCL_PARALLEL_PYTHON_INSTALL_DIR")
    if not (cmake and build and site):
        pytest.skip("run through ctest (CMAKE_COMMAND, PCL_PARALLEL_BUILD_DIR)")
    prefix = tmp_path / "prefix"
    subprocess.run([cmake, "--install", build, "--component", "python", "--prefix",
                    str(prefix)], check=True, stdout=subprocess.DEVNULL)
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env.update(PYTHONPATH=str(prefix / site), PYTHONNOUSERSITE="1")
    code = ("import pcl_parallel, numpy; "
            "print(pcl_parallel.__file__); "
            "print(pcl_parallel.KdTree(numpy.eye(3)).nearest(numpy.eye(3))[0].tolist())")
    out = subprocess.run([sys.executable, "-c", code], env=env, cwd=tmp_path, check=True,
                         capture_output=True, text=True).stdout.split("\n")
    assert out[0].startswith(str(prefix / site))
    assert out[1] == "[0, 1, 2]"
