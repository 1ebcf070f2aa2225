# SPDX-License-Identifier: GPL-3.0-or-later
"""Shared fixtures of the Python package tests (run by ctest with PYTHONPATH=build/python,
RBC_EXECUTABLE=build/rbc and OMP_NUM_THREADS=1, so every reduction sums in one order and the
CLI and the package give bit-identical numbers)."""
import json
import os
import subprocess
import sys

import pytest

import rbc

SOURCE_DIR = os.environ.get("RBC_SOURCE_DIR",
                            os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))


def rbc_executable():
    path = os.environ.get("RBC_EXECUTABLE")
    assert path and os.access(path, os.X_OK), f"RBC_EXECUTABLE={path!r} is not an executable"
    return path


def run_cli_json(*args):
    """Runs `rbc ARGS --json -q`-style commands and returns the parsed JSON on stdout."""
    env = dict(os.environ, OMP_NUM_THREADS="1")
    out = subprocess.run([rbc_executable(), *args], capture_output=True, text=True, env=env,
                         timeout=300)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


@pytest.fixture(scope="session")
def small_mesh():
    """Phi-minimised rest shape with about 250 vertices."""
    return rbc.rest_shape(250)


@pytest.fixture(scope="session")
def small_network(small_mesh):
    return rbc.Network(small_mesh)


@pytest.fixture
def perturbed(small_network):
    """Rest positions randomly perturbed (seeded) by 2 % of the mean link: no symmetry left."""
    import numpy as np

    rng = np.random.default_rng(7)
    x = np.array(small_network.rest_positions)
    return x + 0.02 * small_network.lbar_um.mean() * rng.uniform(-1, 1, x.shape)


def pytest_report_header(config):
    return f"rbc package: {rbc.__file__}, python {sys.executable}"
