# SPDX-License-Identifier: GPL-3.0-or-later
"""One validation for every entry point: the Python package refuses what the CLI refuses.

Forces beyond a model's documented maximum (500 pN discrete, 400 pN continuum) raise ValueError
naming the force and the limit before any solve, as `rbc stretch --force 800` refuses them; NaN
and inf raise ValueError in every binding that takes a number or an array. The table of NaN
cases is checked against the bindings' own signatures, so a new float argument without a case
fails here."""
import math
import re
import time

import numpy as np
import pytest

import rbc

NAN, INF = float("nan"), float("inf")


# ---- force maxima (library validate: StretchOptions / ContinuumOptions::validate(forces)) ----

@pytest.mark.parametrize("model, forces, size, limit, bad", [
    ("discrete", [800], dict(vertices=300), "[0, 500] pN", "got 800 pN"),
    ("discrete", [0, 16, 1e6], dict(vertices=300), "[0, 500] pN", "got 1e+06 pN"),
    ("continuum", [1000], dict(elements=300), "[0, 400] pN", "got 1000 pN"),
    ("continuum", [0, 400.5], dict(elements=300), "[0, 400] pN", "got 400.5 pN"),
])
def test_forces_beyond_the_models_maximum_are_refused_before_any_solve(model, forces, size,
                                                                       limit, bad):
    messages = []
    start = time.process_time()
    with pytest.raises(ValueError) as e:
        rbc.stretch(model, forces, progress=messages.append, **size)
    text = str(e.value)
    assert f"force ({model} model)" in text and limit in text and bad in text, text
    # Refused up front: no force was solved (the solver reports each force it finishes).
    assert not any(m.startswith("F = ") for m in messages), messages
    assert time.process_time() - start < 60  # a solve at 1e6 pN alone takes minutes


def test_the_maximum_itself_is_accepted():
    r = rbc.stretch("continuum", [0, 400], elements=300)
    assert r.forces_pN.tolist() == [0.0, 400.0]
    assert r.axial_um[1] > r.axial_um[0]


def test_monte_carlo_refuses_a_force_beyond_the_discrete_maximum(small_network):
    with pytest.raises(ValueError, match=r"force \(discrete model\) must be finite and in "
                                         r"\[0, 500\] pN, got 800 pN"):
        rbc.MonteCarlo(small_network, force_pN=800.0)


def test_cli_and_python_name_the_same_limit(tmp_path):
    import subprocess
    from conftest import rbc_executable

    out = subprocess.run([rbc_executable(), "stretch", "--vertices", "300", "--force", "800",
                          "-q"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 2, out.stderr
    assert "[0, 500]" in out.stderr
    with pytest.raises(ValueError, match=r"\[0, 500\] pN"):
        rbc.stretch("discrete", [800], vertices=300)


def test_calibration_refuses_data_beyond_the_continuum_maximum(tmp_path):
    data = tmp_path / "beyond.csv"
    data.write_text("force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n"
                    "0,7.82,0.3,7.82,0.3\n38,11.0,0.5,6.6,0.4\n1000,20.0,0.8,4.0,0.4\n")
    with pytest.raises(ValueError) as e:
        rbc.InferenceProblem(parameters=["sigma-scale"], method="continuum:2:200",
                             data_file=str(data))
    text = str(e.value)
    assert str(data) in text and "data row 3" in text and "got 1000 pN" in text, text
    assert "[0, 400] pN" in text, text


# ---- NaN and inf at every binding ----

def _rest(network):
    return np.array(network.rest_positions)


def _with(x, value, at=(3, 1)):
    y = np.array(x, dtype=float)
    y[at] = value
    return y


def _cases(net, mesh):
    """(binding, argument, call) for every numeric or array argument of the bindings."""
    x = _rest(net)
    faces = np.array(mesh.faces)
    return [
        ("Mesh", "positions", lambda v: rbc.Mesh(_with(mesh.positions, v), faces)),
        ("diameters", "positions", lambda v: rbc.diameters(_with(x, v))),
        ("network_energy", "positions", lambda v: rbc.network_energy(net, _with(x, v))),
        ("network_energy", "force_pN", lambda v: rbc.network_energy(net, x, force_pN=v)),
        ("network_energy", "area_multiplier_pN_per_um",
         lambda v: rbc.network_energy(net, x, area_multiplier_pN_per_um=v)),
        ("network_energy", "volume_multiplier_pN_per_um2",
         lambda v: rbc.network_energy(net, x, volume_multiplier_pN_per_um2=v)),
        ("network_energy", "stiffness_scale",
         lambda v: rbc.network_energy(net, x, stiffness_scale=v)),
        ("network_energy_parts", "positions",
         lambda v: rbc.network_energy_parts(net, _with(x, v))),
        ("network_energy_parts", "force_pN",
         lambda v: rbc.network_energy_parts(net, x, force_pN=v)),
        ("network_energy_parts", "area_multiplier_pN_per_um",
         lambda v: rbc.network_energy_parts(net, x, area_multiplier_pN_per_um=v)),
        ("network_energy_parts", "volume_multiplier_pN_per_um2",
         lambda v: rbc.network_energy_parts(net, x, volume_multiplier_pN_per_um2=v)),
        ("network_energy_parts", "stiffness_scale",
         lambda v: rbc.network_energy_parts(net, x, stiffness_scale=v)),
        ("network_hessian", "positions", lambda v: rbc.network_hessian(net, _with(x, v))),
        ("_network_hessian", "area_multiplier_pN_per_um",
         lambda v: rbc.network_hessian(net, x, area_multiplier_pN_per_um=v)),
        ("_network_hessian", "volume_multiplier_pN_per_um2",
         lambda v: rbc.network_hessian(net, x, volume_multiplier_pN_per_um2=v)),
        ("_network_hessian", "stiffness_scale",
         lambda v: rbc.network_hessian(net, x, stiffness_scale=v)),
        ("_network_hessian", "shift_fraction",
         lambda v: rbc.network_hessian(net, x, exact=False, shift_fraction=v)),
        ("network_hessian_operator", "positions",
         lambda v: rbc.network_hessian_operator(net, _with(x, v))),
        ("psi", "deformation", lambda v: rbc.psi("2", [[1.0, 0.0], [0.0, v]])),
        ("moduli", "disorder", lambda v: rbc.moduli(network="disordered", disorder=v)),
        ("thermal_moduli", "sampling_temperature",
         lambda v: rbc._rbc.thermal_moduli(sampling_temperature=v)),
        ("thermal_moduli", "disorder",
         lambda v: rbc._rbc.thermal_moduli(sampling_temperature=0, disorder=v)),
        ("thermal_moduli", "strain",
         lambda v: rbc._rbc.thermal_moduli(sampling_temperature=0, strain=v)),
        ("thermal_energy_pNum", "temperature_K", lambda v: rbc.thermal_energy_pNum(v)),
        ("WlcParameters", "persistence_nm", lambda v: rbc.WlcParameters(persistence_nm=v)),
        ("WlcParameters", "lmax_nm", lambda v: rbc.WlcParameters(lmax_nm=v)),
        ("WlcParameters", "lbar_nm", lambda v: rbc.WlcParameters(lbar_nm=v)),
        ("WlcParameters", "wlc_temperature_K", lambda v: rbc.WlcParameters(wlc_temperature_K=v)),
        ("BendingParameters", "kappa_J", lambda v: rbc.BendingParameters(kappa_J=v)),
        ("BendingParameters", "h0_per_um", lambda v: rbc.BendingParameters(h0_per_um=v)),
        ("StericParameters", "q", lambda v: rbc.StericParameters(q=v)),
        ("StericParameters", "eta", lambda v: rbc.StericParameters(eta=v)),
        ("ContactParameters", "fraction", lambda v: rbc.ContactParameters(fraction=v)),
        *[("_model_objects", name, lambda v, name=name: rbc.ModelParameters(**{name: v}))
          for name in ("lbar_nm", "lmax_nm", "persistence_nm", "temperature_K", "kappa_J",
                       "h0_per_um", "q", "eta", "contact_fraction")],
        ("ConstraintParameters", "area_stiffness_pN_per_um3",
         lambda v: rbc.ConstraintParameters(area_stiffness_pN_per_um3=v)),
        ("ConstraintParameters", "volume_stiffness_pN_per_um5",
         lambda v: rbc.ConstraintParameters(volume_stiffness_pN_per_um5=v)),
        ("ConstraintParameters", "tolerance", lambda v: rbc.ConstraintParameters(tolerance=v)),
        ("ConstraintMultipliers", "area_pN_per_um",
         lambda v: rbc.ConstraintMultipliers(area_pN_per_um=v)),
        ("ConstraintMultipliers", "volume_pN_per_um2",
         lambda v: rbc.ConstraintMultipliers(volume_pN_per_um2=v)),
        ("_stretch_discrete", "forces_pN", lambda v: rbc.stretch("discrete", [0, v], network=net)),
        ("_stretch_discrete", "tolerance_pN",
         lambda v: rbc.stretch("discrete", [0], network=net, tolerance_pN=v)),
        ("_stretch_continuum", "forces_pN",
         lambda v: rbc.stretch("continuum", [v], elements=200)),
        ("_stretch_continuum", "tolerance_pN",
         lambda v: rbc.stretch("continuum", [0], elements=200, tolerance_pN=v)),
        ("MonteCarlo", "force_pN", lambda v: rbc.MonteCarlo(net, force_pN=v)),
        ("MonteCarlo", "sampling_temperature_K",
         lambda v: rbc.MonteCarlo(net, sampling_temperature_K=v)),
        ("MonteCarlo", "penalty_scale", lambda v: rbc.MonteCarlo(net, penalty_scale=v)),
        ("MonteCarlo", "initial_step_um", lambda v: rbc.MonteCarlo(net, initial_step_um=v)),
        ("MonteCarlo", "target_acceptance", lambda v: rbc.MonteCarlo(net, target_acceptance=v)),
        ("MonteCarlo", "adapt_gain", lambda v: rbc.MonteCarlo(net, adapt_gain=v)),
        ("InferenceProblem", "extra_uncertainty_um",
         lambda v: rbc.InferenceProblem(extra_uncertainty_um=v)),
        ("InferenceProblem", "fixed_sigma_scale",
         lambda v: rbc.InferenceProblem(fixed_sigma_scale=v)),
        ("InferenceProblem", "target_cov", lambda v: rbc.InferenceProblem(target_cov=v)),
        ("InferenceProblem", "proposal_scale", lambda v: rbc.InferenceProblem(proposal_scale=v)),
        ("InferenceProblem", "fixed",
         lambda v: rbc.InferenceProblem(parameters=["persistence"], fixed={"kappa_J": v})),
        ("InferenceProblem", "priors",
         lambda v: rbc.InferenceProblem(parameters=["persistence"],
                                        priors={"persistence": (3.0, v)})),
        *[("_dynamics", name, lambda v, name=name: rbc.dynamics(**{name: v}))
          for name in ("force_pN", "membrane_viscosity_pN_s_per_um", "dilatational_ratio",
                       "duration_s", "dt_s", "tolerance_pN_per_s", "normal_drag_pN_s_per_um3",
                       "regulariser")],
    ]


@pytest.fixture(scope="module")
def cases(small_network):
    return _cases(small_network, small_network.mesh)


@pytest.mark.parametrize("value", [NAN, INF, -INF], ids=["nan", "inf", "-inf"])
def test_every_binding_refuses_non_finite_numbers(cases, value):
    for binding, argument, call in cases:
        with pytest.raises(ValueError) as e:
            call(value)
        text = str(e.value)
        assert re.search(r"\b-?(nan|inf)\b", text), (binding, argument, text)


def test_nan_positions_are_named_with_their_entry(small_network):
    x = _with(_rest(small_network), NAN, at=(2, 0))
    for call in (lambda: rbc.network_energy(small_network, x),
                 lambda: rbc.network_hessian(small_network, x),
                 lambda: rbc.Mesh(x, small_network.faces)):
        with pytest.raises(ValueError, match=r"positions: entry 6 of \d+ is nan; expected "
                                             r"finite values"):
            call()


def test_the_finite_values_next_to_them_are_accepted(small_network):
    x = _rest(small_network)
    e, g = rbc.network_energy(small_network, x, force_pN=1e6)  # an energy has no force limit
    assert math.isfinite(e) and np.isfinite(g).all()
    assert rbc.network_hessian(small_network, x).shape == (3 * len(x), 3 * len(x))
    assert rbc.Mesh(x, small_network.faces).num_vertices == len(x)


def test_log_likelihood_refuses_non_finite_theta_and_warm(tmp_path):
    data = tmp_path / "two.csv"
    data.write_text("force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n"
                    "0,7.82,0.3,7.82,0.3\n38,11.0,0.5,6.6,0.4\n")
    p = rbc.InferenceProblem(parameters=["sigma-scale"], method="continuum:2:200",
                             data_file=str(data))
    with pytest.raises(ValueError, match=r"theta: entry 0 of 1 is nan"):
        p.log_likelihood([NAN])
    with pytest.raises(ValueError, match=r"warm: entry 1 of 2 is inf"):
        p.log_likelihood([1.0], warm=[0.0, INF])
    with pytest.raises(ValueError, match=r"theta: entry 0 of 1 is inf"):
        p.forward_state([INF])


def _float_arguments(owner, doc):
    """(owner, argument) of every `float` argument in a pybind11 signature docstring."""
    found = set()
    for line in (doc or "").splitlines():
        m = re.match(r"\s*(?:\d+\.\s*)?\w+\((.*)\) ->", line)
        if m:
            for arg in re.finditer(r"(\w+): (?:float|typing\.SupportsFloat|SupportsFloat)\b",
                                   m.group(1)):
                found.add((owner, arg.group(1)))
    return found


def test_the_nan_table_covers_every_float_argument_of_the_bindings(cases):
    covered = {(b, a) for b, a, _ in cases}
    signatures = set()
    for name in dir(rbc._rbc):
        obj = getattr(rbc._rbc, name)
        if isinstance(obj, type):  # a bound class: its constructor and its methods
            signatures |= _float_arguments(name, obj.__init__.__doc__)
            for attr, fn in vars(obj).items():
                if not attr.startswith("__") and callable(fn):
                    signatures |= _float_arguments(attr, getattr(fn, "__doc__", ""))
        elif callable(obj):
            signatures |= _float_arguments(name, obj.__doc__)
    assert ("network_energy", "force_pN") in signatures  # the docstrings are read at all
    missing = signatures - covered
    assert not missing, f"float arguments without a NaN case: {sorted(missing)}"
