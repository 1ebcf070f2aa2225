# SPDX-License-Identifier: GPL-3.0-or-later
"""rbc.infer (TMCMC, calibrate/) from Python: the CLI's numbers for the same inputs, bad input
named, and the emcee cross-check of examples/emcee_crosscheck.py at small size (one parameter,
a cheap likelihood)."""
import ctypes
import os
import sys

import numpy as np
import pytest

import rbc
from conftest import run_cli_json

EXAMPLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples")
sys.path.insert(0, EXAMPLES)
import emcee_crosscheck  # noqa: E402

METHOD = "continuum:2:200"


@pytest.fixture(scope="module")
def small_data(tmp_path_factory):
    """The default data (Suresh 2005) at two forces, its declarations kept: a cheap forward
    model."""
    return emcee_crosscheck.subset_data(str(tmp_path_factory.mktemp("data") / "suresh2.csv"),
                                        [0.0, 38.0])


def test_infer_equals_rbc_infer(small_data):
    args = dict(parameters=["sigma-scale"], method=METHOD, data_file=small_data, samples=30,
                sampler="tmcmc", seed=4)
    cli = run_cli_json("infer", "--params", "sigma-scale", "--method", METHOD, "--data-file",
                       small_data, "--sampler", "tmcmc", "--samples", "30", "--seed", "4",
                       "--json", "-q")
    py = rbc.infer(**args)
    for key in ("parameters", "derived", "log_evidence", "log_evidence_sd", "stages", "status",
                "method", "elements", "vertices", "seed"):
        assert py[key] == cli[key], key
    assert py["samples"].shape == (30, 1)
    summary = py["parameters"]
    summary = summary[0] if isinstance(summary, list) else summary["sigma-scale"]
    assert py["samples"].mean() == pytest.approx(summary["mean"], rel=1e-12)


def test_laplace_is_equals_rbc_infer_laplace_is(small_data):
    """rbc.infer(sampler='laplace-is') gives ``rbc infer --sampler laplace-is``'s posterior."""
    cli = run_cli_json("infer", "--params", "sigma-scale", "--method", METHOD, "--data-file",
                       small_data, "--sampler", "laplace-is", "--is-samples", "100", "--seed", "4",
                       "--json", "-q")
    py = rbc.infer(parameters=["sigma-scale"], method=METHOD, data_file=small_data,
                   sampler="laplace-is", is_samples=100, seed=4)
    assert py["sampler"] == cli["sampler"] == "laplace-is"
    for key in ("parameters", "derived", "log_evidence", "log_evidence_sd", "ess", "status"):
        assert py[key] == cli[key], key
    assert py["ess"] >= 50


def test_infer_gives_the_process_its_blas_threads_back(small_data):
    # The forward solves run on one OpenBLAS thread; numpy shares that OpenBLAS, so the count
    # must come back afterwards (rbc.infer used to leave 1 for the rest of the session).
    ext = ctypes.CDLL(rbc._rbc.__file__)
    if not hasattr(ext, "openblas_set_num_threads"):
        pytest.skip("the extension's BLAS is not OpenBLAS")
    before = ext.openblas_get_num_threads()
    omp_threads = ext.omp_get_max_threads() if hasattr(ext, "omp_get_max_threads") else None
    ext.openblas_set_num_threads(3)  # no default gives 3 on the project's 2-core machines
    try:
        rbc.infer(parameters=["sigma-scale"], method=METHOD, data_file=small_data, samples=30,
                  sampler="tmcmc", seed=4)
        assert ext.openblas_get_num_threads() == 3
        assert rbc.blas_info()["threads"] == 3
    finally:
        ext.openblas_set_num_threads(before)
        if omp_threads is not None:
            ext.omp_set_num_threads(omp_threads)


def test_bad_inference_input_raises_value_error(small_data):
    with pytest.raises(ValueError, match="'stiffness'"):
        rbc.InferenceProblem(parameters=["stiffness"], data_file=small_data)
    with pytest.raises(ValueError, match="sigma-scale"):
        rbc.InferenceProblem(parameters=["sigma-scale"], priors={"sigma-scale": (2.0, 1.0)},
                             data_file=small_data)
    with pytest.raises(ValueError, match="samples"):
        rbc.InferenceProblem(parameters=["sigma-scale"], samples=0, sampler="tmcmc",
                             data_file=small_data)
    with pytest.raises(ValueError, match="samples 30: a setting of the tmcmc sampler"):
        rbc.InferenceProblem(parameters=["sigma-scale"], samples=30, sampler="laplace-is",
                             data_file=small_data)
    with pytest.raises(ValueError, match="is-samples 300: a setting of the laplace-is sampler"):
        rbc.InferenceProblem(parameters=["sigma-scale"], is_samples=300, sampler="tmcmc",
                             data_file=small_data)
    with pytest.raises(ValueError, match="sampler 'mcmc'"):
        rbc.InferenceProblem(parameters=["sigma-scale"], sampler="mcmc", data_file=small_data)


def test_the_data_carry_their_declared_name_and_uncertainty(small_data):
    """sigma^2 = err^2 + declared^2 + added^2: the file declares 0.1 um, the caller adds 0.2."""
    own = rbc.InferenceProblem(parameters=["sigma-scale"], method=METHOD, data_file=small_data)
    added = rbc.InferenceProblem(parameters=["sigma-scale"], method=METHOD, data_file=small_data,
                                 extra_uncertainty_um=0.2)
    assert own.data["name"] == "Suresh et al. 2005, Fig. 7a/b, healthy cells"
    assert own.data["declared_extra_uncertainty_um"] == 0.1
    assert own.data["added_extra_uncertainty_um"] == 0.0
    assert added.data["added_extra_uncertainty_um"] == 0.2
    err_axial = np.array([0.698, 1.108])  # the 0 and 38 pN rows of the file
    np.testing.assert_allclose(own.data["axial_sigma_um"], np.sqrt(err_axial**2 + 0.01),
                               rtol=1e-14)
    np.testing.assert_allclose(added.data["axial_sigma_um"],
                               np.sqrt(err_axial**2 + 0.01 + 0.04), rtol=1e-14)


def test_log_likelihood_is_the_gaussian_of_the_forward_diameters(small_data):
    """log L(s) for the error-bar scale s is -1/2 chi2/s^2 - n log(sqrt(2 pi) s) - sum log sigma:
    with the forward model fixed, two values of s determine chi2 and the constant."""
    p = rbc.InferenceProblem(parameters=["sigma-scale"], method=METHOD, data_file=small_data)
    warm = p.forward_state([1.0])
    l1, l2, l3 = (p.log_likelihood([s], warm) for s in (1.0, 2.0, 0.7))
    n = 3  # terms: D_A at both forces, D_T at the non-zero force
    # l(s) = a / s^2 - n log s + c
    a = (l1 - l2 - n * np.log(2.0)) / (1 - 0.25)
    c = l1 - a
    assert l3 == pytest.approx(a / 0.49 - n * np.log(0.7) + c, rel=1e-9)
    assert a < 0  # -chi2/2
    assert p.log_likelihood([50.0]) == -np.inf  # outside the prior box


def test_tmcmc_and_emcee_agree_within_four_standard_errors(small_data):
    r = emcee_crosscheck.run(params=("sigma-scale",), method=METHOD, data_file=small_data,
                             samples=200, seed=2, walkers=8, steps=500, burn=100)
    assert r["emcee_tau"][0] < 500 / 20  # the chain is long against its correlation time
    assert r["agree"], r


def test_cancel_stops_the_inference_between_stages(small_data):
    polls = []
    with pytest.raises(KeyboardInterrupt):
        rbc.infer(parameters=["sigma-scale"], method=METHOD, data_file=small_data, samples=20,
                  sampler="tmcmc", cancel=lambda: polls.append(1) or True)
    assert len(polls) == 1  # the first poll (between stages) stopped it


def test_infer_predict_equals_rbc_infer_predict(small_data, tmp_path):
    """rbc.infer(predict=...) gives the predictions of ``rbc infer --predict``; a held-out file
    that cannot be read is refused before any forward run."""
    held = emcee_crosscheck.subset_data(
        str(tmp_path / "mills3.csv"), [16.0, 68.0, 130.5],
        source=os.path.join(os.path.dirname(emcee_crosscheck.DATA),
                            "mills2004_fig8_optical_tweezers.csv"))
    args = dict(parameters=["sigma-scale"], method=METHOD, data_file=small_data, samples=20,
                sampler="tmcmc", seed=4)
    cli = run_cli_json("infer", "--params", "sigma-scale", "--method", METHOD, "--data-file",
                       small_data, "--sampler", "tmcmc", "--samples", "20", "--seed", "4",
                       "--predict", held,
                       "--predict-draws", "8", "--json", "-q")
    py = rbc.infer(predict=[held], predict_draws=8, **args)
    assert py["predictions"] == cli["predictions"]
    (p,) = py["predictions"]
    assert p["name"] == "Mills et al. 2004, Fig. 8" and p["draws"] == 8
    assert p["coverage"]["points"] == {"axial": 3, "transverse": 3, "all": 6}
    messages = []
    with pytest.raises(RuntimeError, match="missing.csv"):
        rbc.infer(predict=[str(tmp_path / "missing.csv")], progress=messages.append, **args)
    assert not any("stage" in m for m in messages), messages
    with pytest.raises(ValueError, match="predict_draws must be >= 0"):
        rbc.infer(predict=[held], predict_draws=-1, progress=messages.append, **args)
    assert not any("stage" in m for m in messages), messages


def test_infer_predicts_a_recovery_file_as_rbc_infer_predict(small_data, tmp_path):
    """A recovery file among predict= (header cell,time_s,length_over_width) is predicted by
    the release scene, as ``rbc infer --predict``: the same "recovery" entry, its coverage
    fractions in [0, 1]."""
    cells = tmp_path / "cells.csv"
    cells.write_text("cell,time_s,length_over_width\n1,0,1.9\n1,0.1,1.5\n1,0.2,1.3\n"
                     "1,0.3,1.2\n")
    cli = run_cli_json("infer", "--params", "sigma-scale", "--method", METHOD, "--data-file",
                       small_data, "--sampler", "tmcmc", "--samples", "20", "--seed", "4",
                       "--predict", str(cells), "--predict-recovery-draws", "2", "--json", "-q")
    py = rbc.infer(parameters=["sigma-scale"], method=METHOD, data_file=small_data,
                   sampler="tmcmc", samples=20, seed=4, predict=[str(cells)],
                   predict_recovery_draws=2)
    assert py["predictions"] == cli["predictions"]
    (p,) = py["predictions"]
    assert p["kind"] == "recovery"
    with pytest.raises(ValueError, match="predict_recovery_draws must be >= 0"):
        rbc.infer(parameters=["sigma-scale"], method=METHOD, data_file=small_data,
                  sampler="tmcmc", samples=20, predict=[str(cells)], predict_recovery_draws=-1)
