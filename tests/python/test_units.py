# SPDX-License-Identifier: GPL-3.0-or-later
"""Units in the keys and one parameter object.

Every key of every dict the package returns (and of `rbc moduli --json` and
`rbc psi --deformation ... --json`) names its unit or is one of rbc.UNITLESS_KEYS; the walk
below fails on any other key. rbc.ModelParameters has the CLI's defaults (read from
`rbc stretch --help` of the built executable), refuses a non-physical value with a ValueError
naming it and its limit, and gives the same stretch as the separate keyword arguments."""
import dataclasses
import os
import pickle
import re
import subprocess

import numpy as np
import pytest

import rbc
from conftest import rbc_executable, run_cli_json

# The unit suffixes, written out here independently of the package's own pattern.
UNIT = r"(?:pNum|pN|uN|J|K|s|nm|um[23]?|m)"
SUFFIX = re.compile(rf"_(?:{UNIT}|per_{UNIT})(?:_per_{UNIT})*$")


def has_unit(key):
    return bool(SUFFIX.search(key))


def unitless_keys(value, inherited=False, path="", seen=None):
    """The keys under `value` (dicts, lists of dicts) that neither name a unit nor are listed
    in rbc.UNITLESS_KEYS. A dict under a key with a unit, or with a "unit" entry, holds numbers
    in that unit (statistics such as mean, error, q05): its keys need no suffix."""
    bad = []
    if seen is not None and isinstance(value, dict):
        seen.update(value)
    if isinstance(value, dict):
        for k, v in value.items():
            self_described = isinstance(v, dict) and "unit" in v
            ok = inherited or has_unit(k) or k in rbc.UNITLESS_KEYS or self_described
            if not ok:
                bad.append(f"{path}{k}")
            bad += unitless_keys(v, inherited or has_unit(k) or self_described,
                                 f"{path}{k}.", seen)
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            bad += unitless_keys(v, inherited, f"{path}[{i}].", seen)
    return bad


def test_the_walk_finds_a_key_without_a_unit():
    # The keys as they were before units were named: each must be caught.
    assert unitless_keys({"mu_closed": 8.3, "K_numeric": 16.5}) == ["mu_closed", "K_numeric"]
    assert unitless_keys({"parts": [{"links": 1.0}]}) == ["parts", "parts.[0].links"]
    assert unitless_keys({"mu_closed_pN_per_um": 8.3, "poisson": 0.33, "h0_per_um": 0.0,
                          "energy_pNum": {"mean": 1.0, "error": 0.1}}) == []


def test_no_unitless_key_has_a_unit_suffix():
    assert not [k for k in rbc.UNITLESS_KEYS if has_unit(k)]


@pytest.fixture(scope="module")
def infer_result(tmp_path_factory):
    data = tmp_path_factory.mktemp("data") / "two.csv"
    data.write_text("force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n"
                    "0,7.82,0.3,7.82,0.3\n38,11.0,0.5,6.6,0.4\n")
    problem = rbc.InferenceProblem(parameters=["sigma-scale"], method="continuum:2:200",
                                   data_file=str(data), samples=20, seed=2,
                                   sampler="tmcmc")
    return problem, rbc.infer(problem)


@pytest.fixture(scope="module")
def returned_dicts(infer_result, predict_result):
    """Every dict the package's public API returns, by the call that returned it."""
    net = rbc.Network(rbc.rest_shape(150))
    mc = rbc.MonteCarlo(net, force_pN=20.0, seed=1)
    mc.run(20)
    hmc = rbc.MonteCarlo(net, force_pN=20.0, seed=1, sampler="hmc")
    hmc.run(20)
    F = np.array([[1.2, 0.1], [0.0, 0.95]])
    discrete = rbc.stretch("discrete", [0, 30], vertices=150, symmetry="mirror")
    continuum = rbc.stretch("continuum", [0, 30], elements=200)
    problem, inferred = infer_result
    return {
        "moduli(hex)": rbc.moduli(),
        "moduli(disordered)": rbc.moduli(network="disordered", cells=4, seeds=2),
        "thermal_moduli": rbc.thermal_moduli(200, cells=4, sweeps=200, warmup_sweeps=50),
        "psi(F)": rbc.psi("full", F),
        "psi(stack)": rbc.psi(2, np.stack([F, np.eye(2)])),
        "blas_info": rbc.blas_info(),
        "MeshQualityReport.to_dict": net.mesh.quality.to_dict(),
        "network_energy_parts": rbc.network_energy_parts(net, net.rest_positions, force_pN=5.0),
        "StretchResult.to_records(discrete)": discrete.to_records(),
        "StretchResult.to_records(continuum)": continuum.to_records(),
        "StretchPoint.fields": continuum[-1].fields,
        "MonteCarlo.summary": mc.summary(),
        "MonteCarlo.summary(sampler='hmc')": hmc.summary(),
        "MonteCarlo.series": mc.series,
        "InferenceProblem.data": problem.data,
        "infer": inferred,
        "ModelParameters.to_dict": rbc.ModelParameters().to_dict(),
        "rbc moduli --json": run_cli_json("moduli", "--json", "-q"),
        "rbc moduli --network disordered --json": run_cli_json(
            "moduli", "--network", "disordered", "--cells", "4", "--seeds", "2", "--json", "-q"),
        "rbc psi --json": run_cli_json("psi", "--deformation", "1.2,0.1,0,0.95", "--json"),
        "rbc infer --predict --json": without_run_record(predict_result),
    }


@pytest.fixture(scope="module")
def predict_result(tmp_path_factory):
    """`rbc infer --json` with a held-out stretch file and a held-out recovery file: the
    "predictions" of both kinds (a tiny fit, 2 draws each, 200-element release scenes)."""
    tmp = tmp_path_factory.mktemp("predict")
    fit = tmp / "fit.csv"
    fit.write_text("force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n"
                   "0,7.82,0.3,7.82,0.3\n38,11.0,0.5,6.6,0.4\n")
    held = tmp / "held.csv"
    held.write_text("force_pN,axial_um,axial_err_um,transverse_um,transverse_err_um\n"
                    "0,7.9,0.3,7.9,0.3\n30,10.5,0.5,6.8,0.4\n")
    cells = tmp / "cells.csv"
    cells.write_text("cell,time_s,length_over_width\n1,0,1.9\n1,0.1,1.5\n1,0.2,1.3\n"
                     "1,0.3,1.2\n")
    return run_cli_json("infer", "--method", "continuum:2:200", "--params", "sigma-scale",
                        "--sampler", "tmcmc", "--samples", "20", "--seed", "2",
                        "--data-file", str(fit),
                        "--predict", str(held), "--predict", str(cells), "--predict-draws", "2",
                        "--predict-recovery-draws", "2", "--recovery-elements", "200", "--json",
                        "-q")


def without_run_record(d):
    """A CLI --json object without its run record (app/run_config.hpp): "config" holds the
    options by their command-line names (units in --help), "provenance" the version, date,
    host and threads."""
    return {k: v for k, v in d.items() if k not in ("config", "provenance")}


def test_every_returned_key_names_its_unit_or_is_documented_unitless(returned_dicts):
    bad = {call: keys for call, d in returned_dicts.items()
           if (keys := unitless_keys(without_run_record(d) if call.startswith("rbc ") else d))}
    assert not bad, f"keys without a unit that rbc.UNITLESS_KEYS does not list: {bad}"


def test_every_documented_unitless_key_occurs(returned_dicts):
    # The list documents the package's keys, not guesses: each entry is returned somewhere
    # (resumed_from_stage only by a resumed `rbc infer`).
    seen = set()
    unitless_keys(list(returned_dicts.values()), seen=seen)
    assert not rbc.UNITLESS_KEYS - seen - {"resumed_from_stage"}


def test_moduli_keys_name_pN_per_um_and_the_values_are_the_closed_forms():
    d = rbc.moduli()
    # MODEL.md section 3: mu = 8.299 uN/m, K = 16.52 uN/m for the default spectrin.
    assert d["mu_closed_pN_per_um"] == pytest.approx(8.299, abs=5e-4)
    assert d["K_closed_pN_per_um"] == pytest.approx(16.52, abs=5e-3)
    E = 4 * d["K_closed_pN_per_um"] * d["mu_closed_pN_per_um"] / (
        d["K_closed_pN_per_um"] + d["mu_closed_pN_per_um"])
    assert d["young_closed_pN_per_um"] == pytest.approx(E, rel=1e-12)


def test_psi_json_of_the_cli_equals_rbc_psi():
    cli = run_cli_json("psi", "--order", "3", "--deformation", "1.2,0.1,0,0.95", "--lmax",
                       "250", "--json")
    py = rbc.psi(3, [[1.2, 0.1], [0.0, 0.95]], parameters=rbc.ModelParameters(lmax_nm=250))
    assert cli.pop("command") == "psi" and cli["config"]["lmax"] == 250
    cli = without_run_record(cli)
    assert set(cli) == set(py)
    for k in cli:
        assert np.array_equal(np.asarray(py[k]), np.asarray(cli[k])), k


def test_psi_json_without_a_deformation_is_refused():
    out = subprocess.run([rbc_executable(), "psi", "--json"], capture_output=True, text=True)
    assert out.returncode == 2 and out.stdout == ""
    assert out.stderr.startswith("rbc: error: --json") and "--deformation" in out.stderr


# ---- ModelParameters ----

def cli_defaults():
    """The Model options' defaults as `rbc stretch --help` prints them ("--lbar FLOAT=75")."""
    text = subprocess.run([rbc_executable(), "stretch", "--help"], capture_output=True,
                          text=True, check=True, env=dict(os.environ, COLUMNS="300")).stdout
    return dict(re.findall(r"^\s*(--[a-z0-9-]+) [A-Z]+(?::\{[^}]*\})?=(\S+)", text, re.M))


FIELD_OPTION = {"lbar_nm": "--lbar", "lmax_nm": "--lmax", "persistence_nm": "--persistence",
                "temperature_K": "--temperature", "kappa_J": "--kappa", "h0_per_um": "--h0",
                "q": "--q", "eta": "--eta", "contact": "--contact",
                "contact_fraction": "--contact-fraction", "bending": "--bending",
                "dihedral_mapping": "--dihedral-mapping"}


def test_model_parameters_mirror_the_cli_options_and_their_defaults():
    cli = cli_defaults()
    p = rbc.ModelParameters()
    assert [f.name for f in dataclasses.fields(p)] == list(FIELD_OPTION)
    for field, option in FIELD_OPTION.items():
        assert option in cli, f"{option} not in `rbc stretch --help`"
        value = getattr(p, field)
        if isinstance(value, str):
            assert value == cli[option], field
        else:
            assert value == float(cli[option]), field


def test_model_parameters_convert_to_the_per_term_objects_with_the_same_values():
    p = rbc.ModelParameters(persistence_nm=9, kappa_J=3e-19, h0_per_um=0.5, q=2, eta=0.01,
                            contact="vertices", contact_fraction=0.1, bending="dihedral",
                            dihedral_mapping="li", temperature_K=310, lmax_nm=250, lbar_nm=80)
    w, b, s, c = p.wlc_parameters, p.bending_parameters, p.steric_parameters, \
        p.contact_parameters
    assert (w.persistence_nm, w.lmax_nm, w.lbar_nm, w.wlc_temperature_K) == (9, 250, 80, 310)
    assert (b.kappa_J, b.h0_per_um) == (3e-19, 0.5)
    assert b.model == rbc.BendingModel.dihedral
    assert b.dihedral_mapping == rbc.DihedralMapping.li_et_al
    assert (s.q, s.eta) == (2, 0.01)
    assert (c.fraction, c.rule) == (0.1, rbc.PatchRule.by_vertex_count)
    assert pickle.loads(pickle.dumps(p)) == p
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.q = 3


@pytest.mark.parametrize("field, value, limit", [
    ("persistence_nm", -1.0, "(0, 10000] nm"),
    ("lmax_nm", 50.0, "(75, 10000] nm"),
    ("lbar_nm", 0.0, "(0, 10000] nm"),
    ("temperature_K", 2000.0, "(0, 1000] K"),
    ("kappa_J", -1e-19, "1e-16] J"),
    ("kappa_J", 0.0, "(0, 1e-16] J"),  # as the CLI: a cell needs bending
    ("h0_per_um", 1e3, "[-100, 100]"),
    ("q", 0.0, "(0, 10]"),
    ("eta", 5.0, "(0, 1]"),
    ("contact_fraction", 0.7, "(0, 0.5)"),
    ("contact", "bead", "area, vertices"),
    ("bending", "helfrich", "juelicher, dihedral"),
    ("dihedral_mapping", "kantor", "sphere, li"),
])
def test_a_non_physical_model_parameter_is_refused_naming_it(field, value, limit):
    with pytest.raises(ValueError) as e:
        rbc.ModelParameters(**{field: value})
    text = str(e.value)
    assert f"{field}={value!r}" in text, text  # the field and the value given
    assert limit in text, text  # the limit of the library's validate()


def test_stretch_with_model_parameters_equals_stretch_with_the_keywords():
    forces = [0, 40]
    new = rbc.stretch("discrete", forces, vertices=150,
                      parameters=rbc.ModelParameters(persistence_nm=10))
    old = rbc.stretch("discrete", forces, vertices=150,
                      wlc=rbc.WlcParameters(persistence_nm=10))
    default = rbc.stretch("discrete", forces, vertices=150)
    assert np.array_equal(new.axial_um, old.axial_um)
    assert np.array_equal(new[-1].positions, old[-1].positions)
    assert new.axial_um[-1] != default.axial_um[-1]  # the parameter reached the solve
    # every shared field reaches the continuum model too
    p = rbc.ModelParameters(lmax_nm=250, kappa_J=3e-19, q=1.5, contact_fraction=0.08)
    a = rbc.stretch("continuum", forces, elements=200, parameters=p)
    b = rbc.stretch("continuum", forces, elements=200,
                    wlc=rbc.WlcParameters(lmax_nm=250),
                    bending=rbc.BendingParameters(kappa_J=3e-19),
                    steric=rbc.StericParameters(q=1.5),
                    contact=rbc.ContactParameters(fraction=0.08))
    assert a.to_records()[-1]["axial_um"] == b.to_records()[-1]["axial_um"]


def test_stretch_with_model_parameters_equals_rbc_stretch_with_the_options():
    cli = run_cli_json("stretch", "--vertices", "150", "--force", "0,40", "--bending",
                       "dihedral", "--dihedral-mapping", "li", "--contact", "vertices",
                       "--h0", "0.3", "--eta", "0.01", "--json", "-q")["points"]
    p = rbc.ModelParameters(bending="dihedral", dihedral_mapping="li", contact="vertices",
                            h0_per_um=0.3, eta=0.01)
    py = rbc.stretch("discrete", [0, 40], vertices=150, parameters=p).to_records()
    for a, b in zip(py, cli):
        assert a["axial_um"] == b["axial_um"] and a["transverse_um"] == b["transverse_um"]


def test_network_moduli_and_psi_take_model_parameters():
    p = rbc.ModelParameters(persistence_nm=10, q=1.5, kappa_J=3e-19)
    mesh = rbc.rest_shape(150)
    a = rbc.Network(mesh, parameters=p)
    b = rbc.Network(mesh, wlc=rbc.WlcParameters(persistence_nm=10),
                    steric=rbc.StericParameters(q=1.5),
                    bending=rbc.BendingParameters(kappa_J=3e-19))
    assert repr(a) == repr(b)
    x = np.asarray(mesh.positions) * 1.01
    assert rbc.network_energy(a, x)[0] == rbc.network_energy(b, x)[0]
    assert rbc.moduli(parameters=p) == rbc.moduli(wlc=p.wlc_parameters,
                                                  steric=p.steric_parameters)
    assert rbc.moduli(parameters=p)["mu_closed_pN_per_um"] != rbc.moduli()["mu_closed_pN_per_um"]
    F = [[1.3, 0.0], [0.0, 1.0]]
    assert rbc.psi(2, F, parameters=p)["psi_pN_per_um"] == rbc.psi(
        2, F, wlc=p.wlc_parameters, steric=p.steric_parameters)["psi_pN_per_um"]


def test_model_parameters_and_the_per_term_keywords_do_not_mix():
    p = rbc.ModelParameters()
    with pytest.raises(ValueError, match="either parameters"):
        rbc.stretch("discrete", [0], vertices=150, parameters=p, wlc=rbc.WlcParameters())
    with pytest.raises(ValueError, match="either parameters"):
        rbc.moduli(parameters=p, steric=rbc.StericParameters())
    with pytest.raises(ValueError, match="either parameters"):
        rbc.Network(rbc.rest_shape(150), parameters=p, bending=rbc.BendingParameters())
    with pytest.raises(TypeError, match="ModelParameters"):
        rbc.stretch("discrete", [0], vertices=150, parameters=rbc.WlcParameters())
