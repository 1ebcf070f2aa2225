# SPDX-License-Identifier: GPL-3.0-or-later
"""The package computes what the CLI computes: same inputs, same numbers (exact comparisons of
the JSON fields, apart from wall-clock timings)."""
import numpy as np
import pytest

import rbc
from conftest import run_cli_json

TIMING = {"wall_s", "sweeps_per_s", "moves_per_s"}


def assert_same(py, cli, keys=None):
    keys = keys if keys is not None else set(cli) & set(py)
    assert keys, "nothing compared"
    for k in sorted(keys - TIMING):
        assert py[k] == cli[k], f"{k}: python {py[k]!r} != cli {cli[k]!r}"


def test_rest_shape_equals_rbc_mesh():
    cli = run_cli_json("mesh", "--vertices", "250", "--json")
    py = rbc.rest_shape(250).quality.to_dict()
    assert set(py) == set(cli) - {"command", "config", "provenance"}  # the CLI's run record
    assert_same(py, cli)


def test_projected_mesh_equals_rbc_mesh():
    cli = run_cli_json("mesh", "--vertices", "300", "--quality", "projected", "--json")
    assert_same(rbc.rest_shape(300, rbc.MeshQuality.projected).quality.to_dict(), cli)


def test_discrete_stretch_equals_rbc_stretch():
    args = ["stretch", "--model", "discrete", "--vertices", "250", "--force", "0,30.6,88",
            "--persistence", "8", "--kappa", "3e-19", "--json", "-q"]
    cli = run_cli_json(*args)["points"]
    res = rbc.stretch("discrete", [0, 30.6, 88], vertices=250,
                      wlc=rbc.WlcParameters(persistence_nm=8),
                      bending=rbc.BendingParameters(kappa_J=3e-19))
    assert len(cli) == len(res) == 3
    for p, c in zip(res.to_records(), cli):
        assert set(p) == set(c)
        assert_same(p, c)
    assert res.converged.all()


def test_continuum_stretch_equals_rbc_stretch():
    cli = run_cli_json("stretch", "--model", "continuum", "--order", "2", "--elements", "400",
                       "--force", "0,50", "--json", "-q")["points"]
    res = rbc.stretch(rbc.Model.continuum, forces_pN=[0, 50], elements=400, order=2)
    for p, c in zip(res.to_records(), cli):
        assert set(p) == set(c)
        assert_same(p, c)


def test_moduli_equal_rbc_moduli():
    cli = run_cli_json("moduli", "--lmax", "250", "--q", "1.5", "--json")
    py = rbc.moduli(wlc=rbc.WlcParameters(lmax_nm=250), steric=rbc.StericParameters(q=1.5))
    # the CLI adds its run record (command, resolved options, provenance) and the timing
    assert set(cli) - set(py) == {"wall_s", "command", "config", "provenance"}
    assert_same(py, cli)
    # and the defaults reproduce MODEL.md's reference numbers
    d = rbc.moduli()
    assert d["mu_closed_pN_per_um"] == pytest.approx(8.299, abs=5e-4)
    assert d["K_closed_pN_per_um"] == pytest.approx(16.52, abs=5e-3)


def test_monte_carlo_equals_rbc_mc():
    cli = run_cli_json("mc", "--vertices", "150", "--force", "20", "--sweeps", "60", "--seed",
                       "3", "--streams", "1", "--json", "-q")
    # Every default is defined once (core/defaults.hpp) and converted once: the library's
    # struct defaults `rbc mc` uses are the natural-unit defaults the Python objects convert,
    # bit for bit, so the default network's chain must be the CLI's bit for bit.
    net = rbc.Network(rbc.rest_shape(150))
    mc = rbc.MonteCarlo(net, force_pN=20, sampling_temperature_K=300, seed=3)
    mc.run(60)
    py = mc.summary()
    keys = {"samples", "discarded_transient", "acceptance", "energy_pNum", "axial_um",
            "transverse_um", "area_um2", "volume_um3", "thermal_shift_axial_um",
            "thermal_shift_transverse_um", "max_area_drift", "max_volume_drift", "sweeps",
            "adaptive_sweeps", "step_um", "reference_axial_um", "reference_transverse_um",
            "running_total_drift_area_um2", "running_total_drift_volume_um3", "colours",
            "chains", "chain_seeds", "per_chain", "converged"}
    assert_same(py, cli, keys)
    # Three chains through both front ends: the same pooled numbers and per-chain series.
    cli3 = run_cli_json("mc", "--vertices", "150", "--force", "20", "--sweeps", "30", "--seed",
                        "3", "--streams", "1", "--chains", "3", "--json", "-q")
    mc3 = rbc.MonteCarlo(net, force_pN=20, sampling_temperature_K=300, seed=3, chains=3)
    mc3.run(30)
    py3 = mc3.summary()
    assert py3["chains"] == cli3["chains"] == 3
    assert_same(py3, cli3, {"axial_um", "energy_pNum", "per_chain", "chain_seeds"})
    assert len(mc3.chain_series(2)["sweep"]) == 30
    with pytest.raises(ValueError, match="chain must be in"):
        mc3.chain_series(3)
    with pytest.raises(ValueError, match="chains"):
        rbc.MonteCarlo(net, force_pN=20, chains=0)


def test_hmc_monte_carlo_equals_rbc_mc_sampler_hmc():
    # The collective sampler through both front ends: the same chain, bit for bit.
    cli = run_cli_json("mc", "--vertices", "150", "--force", "20", "--sweeps", "40", "--seed",
                       "3", "--sampler", "hmc", "--json", "-q")
    net = rbc.Network(rbc.rest_shape(150))
    mc = rbc.MonteCarlo(net, force_pN=20, sampling_temperature_K=300, seed=3, sampler="hmc")
    mc.run(40)
    py = mc.summary()
    assert py["sampler"] == cli["sampler"] == "hmc"
    assert_same(py, cli, {"energy_pNum", "axial_um", "transverse_um", "acceptance", "step_um",
                          "sweeps"})
    with pytest.raises(ValueError, match="metropolis, hmc"):
        rbc.MonteCarlo(net, force_pN=20, sampler="gibbs")


def test_hmc_exact_area_volume_equals_rbc_mc():
    # Exact area and volume constraints through both front ends: the same chain, bit for bit.
    cli = run_cli_json("mc", "--vertices", "150", "--force", "20", "--sweeps", "30", "--seed",
                       "3", "--sampler", "hmc", "--hmc-area-volume", "exact", "--json", "-q")
    net = rbc.Network(rbc.rest_shape(150))
    mc = rbc.MonteCarlo(net, force_pN=20, sampling_temperature_K=300, seed=3, sampler="hmc",
                        hmc_area_volume="exact")
    mc.run(30)
    py = mc.summary()
    assert py["hmc"]["area_volume"] == cli["hmc"]["area_volume"] == "exact"
    assert py["max_area_drift"] <= 1e-10
    assert_same(py, cli, {"energy_pNum", "axial_um", "transverse_um", "acceptance", "step_um",
                          "sweeps"})
    with pytest.raises(ValueError, match="penalty or exact"):
        rbc.MonteCarlo(net, force_pN=20, sampler="hmc", hmc_area_volume="hard")
    # An option of the HMC sampler is refused with the Metropolis one, as `rbc mc` refuses it.
    with pytest.raises(ValueError, match="hmc_area_volume applies to sampler='hmc'"):
        rbc.MonteCarlo(net, force_pN=20, sampler="metropolis", hmc_area_volume="exact")


def test_psi_equals_rbc_psi_table(tmp_path):
    import csv
    import subprocess
    from conftest import rbc_executable

    out = tmp_path / "psi.csv"
    subprocess.run([rbc_executable(), "psi", "--order", "full", "--curve", "uniaxial", "--points",
                    "20", "--out", str(out)], check=True, capture_output=True)
    rows = [r for r in csv.reader(l for l in open(out) if not l.startswith("#"))]
    header, rows = rows[0], np.array(rows[1:], dtype=float)
    s = rows[:, header.index("s")]
    F = np.zeros((len(s), 2, 2))
    F[:, 0, 0], F[:, 1, 1] = s, 1.0
    d = rbc.psi("full", F)
    # the CSV holds 10 significant digits
    np.testing.assert_allclose(d["psi_pN_per_um"], rows[:, header.index("psi_pN_per_um")],
                               rtol=1e-9)
    np.testing.assert_allclose(d["first_piola_pN_per_um"][:, 0, 0],
                               rows[:, header.index("P11_pN_per_um")], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(d["I2"], rows[:, header.index("I2")], rtol=1e-9, atol=1e-12)
