#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Cross-check of the calibration: rbc.infer (TMCMC, the library behind `rbc infer`) against
emcee (Foreman-Mackey et al. 2013, an independent, well-kept affine-invariant ensemble sampler)
on the same likelihood, rbc.InferenceProblem.log_likelihood.

The posterior means must agree within four combined Monte Carlo standard errors: emcee's from
its integrated autocorrelation time tau (se = sd sqrt(tau / (walkers x steps))), TMCMC's from
the number of distinct samples of its final, resampled population (se = sd / sqrt(distinct)).

    PYTHONPATH=build/python /usr/bin/python3 examples/emcee_crosscheck.py \\
        --params sigma-scale --method continuum:2:300
(the default: one parameter whose forward model is solved once, so the likelihood is cheap;
--params persistence runs a real forward solve per evaluation and takes minutes.)
"""
import argparse
import os

import numpy as np

import rbc

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data",
                    "suresh2005_healthy_optical_tweezers.csv")


def subset_data(path_out, forces_pN, source=DATA):
    """Writes the data file restricted to the given forces (same format) and returns its path."""
    with open(source) as f:
        lines = f.readlines()
    header = [l for l in lines if l.startswith("#")]
    rows = [l for l in lines if not l.startswith("#")]
    keep = [rows[0]] + [r for r in rows[1:] if r.strip() and float(r.split(",")[0]) in forces_pN]
    with open(path_out, "w") as f:
        f.writelines(header + keep)
    return path_out


def run(params=("sigma-scale",), method="continuum:2:300", data_file="", samples=400, seed=1,
        walkers=8, steps=600, burn=100):
    import emcee

    problem = rbc.InferenceProblem(parameters=list(params), method=method, data_file=data_file,
                                   samples=samples, seed=seed, sampler="tmcmc")
    lo, hi = problem.prior_lower, problem.prior_upper

    # TMCMC (the library's sampler)
    tm = rbc.infer(problem)
    s = tm["samples"]
    distinct = len(np.unique(s, axis=0))
    tm_mean, tm_sd = s.mean(axis=0), s.std(axis=0, ddof=1)
    tm_se = tm_sd / np.sqrt(distinct)

    # emcee on the same log-likelihood plus the same uniform prior box; the forward solves
    # start from the equilibria at the prior centre (the result is the same to the solver
    # tolerance; with sigma-scale alone the forward model does not depend on theta at all).
    warm = problem.forward_state(0.5 * (lo + hi))

    def log_prob(theta):
        if np.any(theta <= lo) or np.any(theta >= hi):
            return -np.inf
        return problem.log_likelihood(theta, warm)

    rng = np.random.default_rng(seed)
    p0 = lo + (hi - lo) * rng.uniform(0.25, 0.75, (walkers, len(lo)))
    sampler = emcee.EnsembleSampler(walkers, len(lo), log_prob)
    sampler.random_state = np.random.RandomState(seed).get_state()
    sampler.run_mcmc(p0, steps, progress=False)
    chain = sampler.get_chain(discard=burn, flat=True)
    tau = sampler.get_autocorr_time(discard=burn, tol=0)
    em_mean, em_sd = chain.mean(axis=0), chain.std(axis=0, ddof=1)
    em_se = em_sd * np.sqrt(tau / chain.shape[0])

    z = np.abs(tm_mean - em_mean) / np.sqrt(tm_se**2 + em_se**2)
    return dict(names=problem.names, tmcmc_mean=tm_mean, tmcmc_sd=tm_sd, tmcmc_se=tm_se,
                tmcmc_distinct=distinct, emcee_mean=em_mean, emcee_sd=em_sd, emcee_se=em_se,
                emcee_tau=tau, combined_errors=z, agree=bool(np.all(z < 4.0)),
                log_evidence=tm["log_evidence"] if "log_evidence" in tm else None)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--params", default="sigma-scale")
    ap.add_argument("--method", default="continuum:2:300")
    ap.add_argument("--data-file", default="")
    ap.add_argument("--forces", default="",
                    help="restrict the data to these forces (pN), e.g. 0,38,88")
    ap.add_argument("--samples", type=int, default=400)
    ap.add_argument("--walkers", type=int, default=8)
    ap.add_argument("--steps", type=int, default=600)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    data = a.data_file
    if a.forces:
        import tempfile

        data = subset_data(os.path.join(tempfile.mkdtemp(), "data.csv"),
                           [float(f) for f in a.forces.split(",")], a.data_file or DATA)
    r = run(a.params.split(","), a.method, data, a.samples, a.seed, a.walkers, a.steps)
    for k, name in enumerate(r["names"]):
        print(f"{name}: TMCMC {r['tmcmc_mean'][k]:.5f} +- {r['tmcmc_se'][k]:.5f} (sd "
              f"{r['tmcmc_sd'][k]:.4f}, {r['tmcmc_distinct']} distinct), emcee "
              f"{r['emcee_mean'][k]:.5f} +- {r['emcee_se'][k]:.5f} (sd {r['emcee_sd'][k]:.4f}, "
              f"tau {r['emcee_tau'][k]:.1f}): {r['combined_errors'][k]:.2f} combined errors apart")
    print("agree within 4 combined standard errors:", r["agree"])
    return 0 if r["agree"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
