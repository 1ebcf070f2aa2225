#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Minimise the spectrin network's free energy with scipy.optimize instead of the project's own
solver, and check that both land on the same equilibrium.

The area and volume are held by the augmented Lagrangian: rbc.stretch returns, per force, the
multipliers and penalty scale of its last minimisation, so with those held fixed the equilibrium
is a plain minimum of rbc.network_energy, which scipy's L-BFGS-B finds from a perturbed start.

    PYTHONPATH=build/python /usr/bin/python3 examples/scipy_minimise.py --vertices 250 --force 88
"""
import argparse

import numpy as np
import scipy.optimize

import rbc


def run(vertices=250, force_pN=88.0, perturbation_um=0.01, seed=1):
    """Returns the project's and scipy's diameters (um) and scipy's result."""
    res = rbc.stretch("discrete", [0.0, force_pN], vertices=vertices, check=True)
    eq = res[-1]
    net = res.network
    load = dict(force_pN=force_pN, area_multiplier_pN_per_um=eq.area_multiplier_pN_per_um,
                volume_multiplier_pN_per_um2=eq.volume_multiplier_pN_per_um2,
                stiffness_scale=eq.stiffness_scale)
    rng = np.random.default_rng(seed)
    x0 = np.array(eq.positions) + perturbation_um * rng.uniform(-1, 1, eq.positions.shape)

    def f(flat):
        return rbc.network_energy(net, flat, **load)  # flat (3N,) in, flat gradient out

    opt = scipy.optimize.minimize(f, x0.reshape(-1), jac=True, method="L-BFGS-B",
                                  options=dict(maxiter=20000, maxcor=20, ftol=0.0, gtol=1e-6))
    x = opt.x.reshape(-1, 3)
    return dict(project_um=(eq.axial_um, eq.transverse_um), scipy_um=rbc.diameters(x),
                start_um=rbc.diameters(x0), largest_force_pN=np.abs(opt.jac).max(),
                iterations=opt.nit, message=str(opt.message))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vertices", type=int, default=250)
    ap.add_argument("--force", type=float, default=88.0, help="bead force (pN)")
    a = ap.parse_args()
    r = run(a.vertices, a.force)
    print(f"project's solver: D_A = {r['project_um'][0]:.6f} um, D_T = {r['project_um'][1]:.6f} um")
    print(f"scipy L-BFGS-B:   D_A = {r['scipy_um'][0]:.6f} um, D_T = {r['scipy_um'][1]:.6f} um "
          f"({r['iterations']} iterations, largest gradient entry {r['largest_force_pN']:.1e} pN)")


if __name__ == "__main__":
    main()
