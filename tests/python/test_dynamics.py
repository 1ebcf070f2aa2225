# SPDX-License-Identifier: GPL-3.0-or-later
"""rbc.dynamics computes what `rbc dynamics --json` computes: the same scene of either model
gives the same summary and the same samples, compared exactly (apart from the wall-clock time);
bad arguments raise ValueError naming the argument, its value and the limit."""
import math

import numpy as np
import pytest

import rbc
from conftest import run_cli_json

TIMING = {"wall_s"}
# What produced a CLI run (command, resolved options, provenance): the CLI's alone.
RECORD = {"command", "config", "provenance"}

# Short scenes (0.1-0.3 s each): coarse meshes, 10 steps.
CASES = [
    # discrete release: the recovery fit and Hochmuth's curve
    (["--model", "discrete", "--scene", "release", "-n", "250", "--force", "50",
      "--duration", "0.05", "--dt", "0.005"],
     dict(model="discrete", scene="release", vertices=250, force_pN=50, duration_s=0.05,
          dt_s=0.005)),
    # discrete stretch, BDF2, a non-default viscosity
    (["--model", "discrete", "--scene", "stretch", "--scheme", "bdf2", "-n", "250", "--force",
      "40", "--membrane-viscosity", "0.9", "--duration", "0.05", "--dt", "0.005"],
     dict(model="discrete", scene="stretch", scheme="bdf2", vertices=250, force_pN=40,
          membrane_viscosity_pN_s_per_um=0.9, duration_s=0.05, dt_s=0.005)),
    # continuum stretch, law of order 3, a non-default dilatational ratio
    (["--model", "continuum", "--scene", "stretch", "--elements", "400", "--order", "3",
      "--force", "50", "--dilatational-ratio", "1.5", "--duration", "0.05", "--dt", "0.005"],
     dict(model="continuum", scene="stretch", elements=400, order=3, force_pN=50,
          dilatational_ratio=1.5, duration_s=0.05, dt_s=0.005)),
    # continuum release
    (["--model", "continuum", "--scene", "release", "--elements", "400", "--force", "50",
      "--duration", "0.05", "--dt", "0.005"],
     dict(model=rbc.Model.continuum, scene="release", elements=400, force_pN=50, duration_s=0.05,
          dt_s=0.005)),
    # the model option group: --persistence and --kappa as the parameter objects
    (["--model", "discrete", "--scene", "release", "-n", "250", "--force", "50",
      "--persistence", "10", "--kappa", "3e-19", "--duration", "0.05", "--dt", "0.005"],
     dict(model="discrete", scene="release", vertices=250, force_pN=50, duration_s=0.05,
          dt_s=0.005, wlc=rbc.WlcParameters(persistence_nm=10),
          bending=rbc.BendingParameters(kappa_J=3e-19))),
    (["--model", "continuum", "--scene", "stretch", "--elements", "400", "--force", "50",
      "--persistence", "10", "--duration", "0.05", "--dt", "0.005"],
     dict(model="continuum", scene="stretch", elements=400, force_pN=50, duration_s=0.05,
          dt_s=0.005, wlc=rbc.WlcParameters(persistence_nm=10))),
    # continuum relax (the static relaxation too)
    (["--model", "continuum", "--scene", "relax", "--elements", "400", "--duration", "0.2",
      "--dt", "0.1"],
     dict(model="continuum", scene="relax", elements=400, duration_s=0.2, dt_s=0.1)),
]


@pytest.mark.parametrize("args,kwargs", CASES, ids=lambda c: None)
def test_dynamics_equals_rbc_dynamics_json(args, kwargs):
    cli = run_cli_json("dynamics", *args, "--json", "-q")
    res = rbc.dynamics(**kwargs)
    py = res.to_dict()
    assert set(py) == set(cli) - RECORD
    for k in sorted(set(py) - TIMING):
        assert py[k] == cli[k], f"{k}: python {py[k]!r} != cli {cli[k]!r}"
    # The arrays are the samples the CLI prints (all of them: fewer than 200), bit for bit.
    samples = cli["samples"]
    steps = round(kwargs["duration_s"] / kwargs["dt_s"])
    assert len(samples) == len(res.time_s) == steps + 1
    for name in ("t_s", "axial_um", "transverse_um", "energy_pNum"):
        column = res.time_s if name == "t_s" else getattr(res, name)
        assert isinstance(column, np.ndarray) and column.dtype == np.float64
        assert column.tolist() == [s[name] for s in samples], name
    assert res.time_s[-1] == pytest.approx(kwargs["duration_s"], rel=1e-12)
    assert res.positions.shape == (len(res.time_s), res.vertices, 3)
    assert res.faces.shape[1] == 3
    if py["scene"] == "release":
        assert res.recovery_time_s == cli["recovery_time_s"]
        assert res.aspect_ratio[-1] == res.axial_um[-1] / res.transverse_um[-1]
    # The repr is a summary, not the arrays.
    text = repr(res)
    assert text.startswith("DynamicsResult(") and len(text) < 300 and "[" not in text


@pytest.mark.parametrize("kwargs,named", [
    (dict(dt_s=0.0), ["dt_s = 0", "> 0 s"]),
    (dict(dt_s=0.2, duration_s=0.1), ["dt_s = 0.2", "at most the duration 0.1 s"]),
    (dict(model="discrete", force_pN=600.0), ["force_pN = 600", "(0, 500] pN"]),
    (dict(model="continuum", force_pN=450.0), ["force_pN = 450", "(0, 400] pN"]),
    (dict(membrane_viscosity_pN_s_per_um=-0.5), ["membrane_viscosity_pN_s_per_um = -0.5", "> 0"]),
    (dict(model="discrete", vertices=50), ["vertices = 50", "[100, 40000]"]),
    (dict(regulariser=2.0), ["regulariser = 2", "(0, 1]"]),
    (dict(model="discrete", scene="relax"), ["scene = relax", "continuum"]),
    (dict(scheme="bdf2"), ["scheme = bdf2", "discrete model only"]),
    (dict(scene="nope"), ["scene = 'nope'", "release, stretch, relax"]),
    (dict(duration_s=math.inf), ["duration_s = inf", "finite"]),
    (dict(force_pN=math.nan), ["force_pN = nan", "finite"]),
])
def test_bad_arguments_raise_value_error_naming_value_and_limit(kwargs, named):
    polled = []
    with pytest.raises(ValueError) as e:
        rbc.dynamics(**kwargs, cancel=lambda: polled.append(1) or False)
    for text in named:
        assert text in str(e.value), str(e.value)
    assert polled == []  # refused before any work


def test_cancel_stops_the_run_with_keyboard_interrupt():
    polls = []

    def cancel():
        polls.append(1)
        return len(polls) > 3

    with pytest.raises(KeyboardInterrupt):
        rbc.dynamics("discrete", vertices=250, force_pN=50, duration_s=0.05, dt_s=0.005,
                     cancel=cancel)
    assert len(polls) == 4
