# SPDX-License-Identifier: GPL-3.0-or-later
"""rbc.network_energy and rbc.network_hessian against finite differences taken from Python, and a
scipy minimisation of the network energy against the project's own equilibrium."""
import os
import sys

import numpy as np
import pytest

import rbc

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "examples"))

LOAD = dict(force_pN=40.0, area_multiplier_pN_per_um=3.0, volume_multiplier_pN_per_um2=-1.5,
            stiffness_scale=2.0)


def observed_orders(errors):
    e = np.asarray(errors)
    return np.log2(e[:-1] / e[1:])


def test_gradient_matches_central_differences_at_second_order(small_network, perturbed):
    rng = np.random.default_rng(11)
    v = rng.standard_normal(perturbed.shape)
    v /= np.linalg.norm(v)
    e, g = rbc.network_energy(small_network, perturbed, **LOAD)
    assert np.isfinite(e) and g.shape == perturbed.shape
    exact = float(np.sum(g * v))
    h0 = 0.01 * small_network.lbar_um.mean()
    errors = []
    for k in range(4):
        h = h0 / 2**k
        ep, _ = rbc.network_energy(small_network, perturbed + h * v, **LOAD)
        em, _ = rbc.network_energy(small_network, perturbed - h * v, **LOAD)
        errors.append(abs((ep - em) / (2 * h) - exact))
    orders = observed_orders(errors)
    assert np.all((orders > 1.7) & (orders < 2.3)), (errors, orders)
    assert errors[-1] < 1e-4 * abs(exact)


def test_flat_positions_give_flat_gradient(small_network, perturbed):
    e1, g1 = rbc.network_energy(small_network, perturbed, **LOAD)
    e2, g2 = rbc.network_energy(small_network, perturbed.reshape(-1), **LOAD)
    assert e1 == e2 and g2.shape == (perturbed.size,)
    assert np.array_equal(g1.reshape(-1), g2)


def test_hessian_matches_differences_of_the_gradient(small_network, perturbed):
    H = rbc.network_hessian(small_network, perturbed, penalty=True,
                            **{k: v for k, v in LOAD.items() if k != "force_pN"})
    n = perturbed.size
    assert H.shape == (n, n) and H.format == "csr"
    assert abs(H - H.T).max() <= 1e-12 * abs(H).max()
    rng = np.random.default_rng(5)
    v = rng.standard_normal(n)
    v /= np.linalg.norm(v)
    exact = H @ v
    h0 = 0.01 * small_network.lbar_um.mean()
    errors = []
    for k in range(4):
        h = h0 / 2**k
        _, gp = rbc.network_energy(small_network, perturbed.reshape(-1) + h * v, **LOAD)
        _, gm = rbc.network_energy(small_network, perturbed.reshape(-1) - h * v, **LOAD)
        errors.append(np.linalg.norm((gp - gm) / (2 * h) - exact))
    orders = observed_orders(errors)
    assert np.all((orders > 1.7) & (orders < 2.3)), (errors, orders)
    assert errors[-1] < 1e-4 * np.linalg.norm(exact)


def test_hessian_operator_equals_the_full_matrix(small_network, perturbed):
    kw = {k: v for k, v in LOAD.items() if k != "force_pN"}
    H = rbc.network_hessian(small_network, perturbed, penalty=True, **kw)
    op = rbc.network_hessian_operator(small_network, perturbed, **kw)
    v = np.random.default_rng(2).standard_normal(perturbed.size)
    np.testing.assert_allclose(op @ v, H @ v, rtol=1e-12, atol=1e-9)
    # the projected Newton matrix is positive semidefinite (smallest eigenvalue ~ 0 up to the
    # rigid modes), the exact Hessian of a perturbed mesh is not required to be
    P = rbc.network_hessian(small_network, perturbed, exact=False, **kw).toarray()
    assert np.linalg.eigvalsh(P).min() > -1e-8 * np.abs(P).max()


def test_scipy_minimisation_lands_on_the_project_equilibrium():
    import scipy_minimise

    r = scipy_minimise.run(vertices=250, force_pN=88.0, perturbation_um=0.01)
    project, scipy_um, start = map(np.asarray, (r["project_um"], r["scipy_um"], r["start_um"]))
    # the start is off by more than the tolerance, the end is within it
    assert np.abs(start / project - 1).max() > 1e-4
    np.testing.assert_allclose(scipy_um, project, rtol=1e-4)


def grad_phi(x, edges, faces):
    """Gradient of Phi = 1/2 sum_e L_e^2 - sqrt3 sum_f A_f (um), computed here with numpy."""
    g = np.zeros_like(x)
    d = x[edges[:, 0]] - x[edges[:, 1]]
    np.add.at(g, edges[:, 0], d)
    np.add.at(g, edges[:, 1], -d)
    a, b, c = (x[faces[:, k]] for k in range(3))
    n = np.cross(b - a, c - a)
    n /= np.linalg.norm(n, axis=1)[:, None]
    for k, (p, q) in enumerate(((c, b), (a, c), (b, a))):  # dA/da = n x (c - b) / 2, cyclic
        np.add.at(g, faces[:, k], -np.sqrt(3) * 0.5 * np.cross(n, p - q))
    return g


def test_rest_force_is_the_equilateral_defect_gradient(small_mesh):
    """MODEL.md: at the rest shape the in-plane force is exactly (f_WLC(Lbar)/Lbar) grad Phi for
    any mesh (each element is stress-free at its own reference). Bending off (kappa = 0), no
    load: the whole gradient is in-plane."""
    wlc = rbc.WlcParameters()
    net = rbc.Network(small_mesh, bending=rbc.BendingParameters(kappa_J=0.0), wlc=wlc)
    _, g = rbc.network_energy(net, net.rest_positions)
    kT = rbc.thermal_energy_pNum(wlc.wlc_temperature_K)
    p, lbar, lmax = (1e-3 * v for v in (wlc.persistence_nm, wlc.lbar_nm, wlc.lmax_nm))
    x = lbar / lmax
    f_wlc = kT / p * (0.25 / (1 - x) ** 2 - 0.25 + x)  # pN, the WLC tension at Lbar
    expected = f_wlc / lbar * grad_phi(np.asarray(net.rest_positions), net.edges, net.faces)
    np.testing.assert_allclose(g, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    assert np.abs(expected).max() > 1e-3  # a real mesh is not all-equilateral
