# pytest fixtures of the Python module's tests. ctest passes the paths by environment
# (test/CMakeLists.txt); run by hand:
#   PYTHONPATH=build/python PCL_PARALLEL_DATA_DIR=../shared/data \
#     /usr/bin/python3 -m pytest test/python
import os
import subprocess

import numpy as np
import pytest


def _env_path(name):
    value = os.environ.get(name, "")
    return value if value and os.path.exists(value) else None


@pytest.fixture(scope="session")
def data_dir():
    path = _env_path("PCL_PARALLEL_DATA_DIR")
    if path is None:
        pytest.skip("reference data not found: set PCL_PARALLEL_DATA_DIR to ../shared/data "
                    "(CMake cache variable of the same name)")
    return path


@pytest.fixture(scope="session")
def reference():
    """Runs pcl_parallel_py_reference (test/python/reference.cpp): the C++ calls."""
    exe = _env_path("PCL_PARALLEL_PY_REFERENCE")
    if exe is None:
        pytest.skip("PCL_PARALLEL_PY_REFERENCE not set: run through ctest")

    def run(*args):
        subprocess.run([exe, *map(str, args)], check=True)
    return run


@pytest.fixture(scope="session")
def pslam():
    exe = _env_path("PCL_PSLAM")
    if exe is None:
        pytest.skip("PCL_PSLAM not set (pcl_pslam not built, or not run through ctest)")
    return exe


@pytest.fixture(scope="session")
def dtk_dir(data_dir):
    path = os.path.join(data_dir, "3dtk_dat")
    if not os.path.isdir(path):
        pytest.skip(f"{path} absent")
    return path


def layouts(points):
    """The same points as float64, float32, Fortran-ordered and as a strided slice."""
    p64 = np.asarray(points, dtype=np.float64)
    wide = np.zeros((len(p64), 7), dtype=np.float64)
    wide[:, 2:5] = p64
    return {
        "float64": p64,
        "float32": p64.astype(np.float32),
        "fortran": np.asfortranarray(p64),
        "fortran32": np.asfortranarray(p64.astype(np.float32)),
        "sliced": wide[:, 2:5],
        "negative_strides": p64[::-1].copy()[::-1],
    }
