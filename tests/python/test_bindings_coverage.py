# SPDX-License-Identifier: GPL-3.0-or-later
"""Bindings checked against independent truths: rbc.network_energy_parts (its parts sum to
rbc.network_energy's total; the tweezer, constraint and penalty parts follow their formulas,
evaluated here in numpy), rbc.MonteCarlo.series (its length, sweeps and last sample follow the
run; its production means are the summary's) and rbc.continuum_mesh (a closed surface of the
sphere's topology with the element count asked for, the Evans-Fung volume and an area that
converges to the Evans-Fung area at second order in the edge length)."""
import numpy as np
import pytest

import rbc

# MODEL.md section 1: the Evans-Fung rest shape's area and volume (4 significant digits).
EVANS_FUNG_AREA_UM2 = 134.09
EVANS_FUNG_VOLUME_UM3 = 94.09


def area_volume(x, faces):
    """Total area (um^2) and enclosed volume (um^3) of a closed outward-oriented triangulation:
    A = sum |(b - a) x (c - a)| / 2, V = sum a . ((b - a) x (c - a)) / 6 (divergence theorem)."""
    f = np.asarray(faces)
    a, b, c = x[f[:, 0]], x[f[:, 1]], x[f[:, 2]]
    n = np.cross(b - a, c - a)
    return 0.5 * np.linalg.norm(n, axis=1).sum(), np.einsum("ij,ij->i", a, n).sum() / 6.0


# ---- network_energy_parts ----

def test_energy_parts_sum_to_the_total_of_network_energy(small_network, perturbed):
    kw = dict(force_pN=30.0, area_multiplier_pN_per_um=0.4, volume_multiplier_pN_per_um2=-0.02,
              stiffness_scale=3.0)
    parts = rbc.network_energy_parts(small_network, perturbed, **kw)
    assert set(parts) == {"links_pNum", "steric_pNum", "bending_pNum", "constraints_pNum",
                          "tweezers_pNum", "total_pNum"}
    total, _ = rbc.network_energy(small_network, perturbed, **kw)
    terms = [parts[k] for k in ("links_pNum", "steric_pNum", "bending_pNum", "constraints_pNum",
                                "tweezers_pNum")]
    # The two calls sum the same terms (possibly in another order): last bits only.
    assert parts["total_pNum"] == pytest.approx(total, rel=1e-12)
    assert sum(terms) == pytest.approx(total, rel=1e-12)
    # Every physical term is there: links, steric and bending are positive on a perturbed cell.
    assert parts["links_pNum"] > 0 and parts["steric_pNum"] > 0 and parts["bending_pNum"] > 0


def test_tweezer_part_is_the_bead_work_and_the_others_do_not_see_the_force(small_network,
                                                                           perturbed):
    at0 = rbc.network_energy_parts(small_network, perturbed, force_pN=0.0)
    at = rbc.network_energy_parts(small_network, perturbed, force_pN=45.0)
    assert at0["tweezers_pNum"] == 0.0
    # E_tweezers = -F sum_i share_i (x_i - X_i) . e_x over the bead-bound vertices.
    v = small_network.contact_vertices
    dx = perturbed[v, 0] - np.asarray(small_network.rest_positions)[v, 0]
    work = -45.0 * np.dot(small_network.contact_shares, dx)
    assert at["tweezers_pNum"] == pytest.approx(work, rel=1e-12)
    for k in ("links_pNum", "steric_pNum", "bending_pNum", "constraints_pNum"):
        assert at[k] == pytest.approx(at0[k], rel=1e-13), k


def test_constraint_part_follows_the_multipliers_and_the_penalty_scale(small_network, perturbed):
    A, V = area_volume(perturbed, small_network.faces)
    dA, dV = A - small_network.area0_um2, V - small_network.volume0_um3
    assert abs(dA) > 1e-6 and abs(dV) > 1e-6  # the perturbation moved both
    base = rbc.network_energy_parts(small_network, perturbed)["constraints_pNum"]
    # Multiplier terms lambda_A (A - A0) + lambda_V (V - V0), added to the penalties.
    la, lv = 0.7, -0.03
    with_l = rbc.network_energy_parts(small_network, perturbed, area_multiplier_pN_per_um=la,
                                      volume_multiplier_pN_per_um2=lv)["constraints_pNum"]
    assert with_l - base == pytest.approx(la * dA + lv * dV, rel=1e-9, abs=1e-12 * abs(base))
    # The penalties s kA/2 (A - A0)^2 + s kV/2 (V - V0)^2 are linear in the scale s.
    scaled = rbc.network_energy_parts(small_network, perturbed,
                                      stiffness_scale=2.5)["constraints_pNum"]
    assert base > 0
    assert scaled == pytest.approx(2.5 * base, rel=1e-12)


def test_energy_parts_at_the_rest_shape_have_no_constraint_or_tweezer_energy(small_network):
    p = rbc.network_energy_parts(small_network, small_network.rest_positions)
    # A = A0 and V = V0 at rest (to rounding): the penalties are (rounding)^2.
    assert abs(p["constraints_pNum"]) < 1e-12 * p["total_pNum"]
    assert p["tweezers_pNum"] == 0.0


# ---- MonteCarlo.series ----

@pytest.fixture(scope="module")
def chain():
    net = rbc.Network(rbc.rest_shape(150))
    mc = rbc.MonteCarlo(net, force_pN=20.0, sampling_temperature_K=300.0, seed=3, sample_every=2)
    mc.run(200)
    return mc


def test_series_has_one_row_per_sample_interval_and_its_last_row_is_the_chain(chain):
    s = chain.series
    assert set(s) == {"sweep", "energy_pNum", "axial_um", "transverse_um", "area_um2",
                      "volume_um3", "acceptance", "step_um"}
    assert all(len(v) == 100 for v in s.values())  # 200 sweeps, one sample every 2
    np.testing.assert_array_equal(s["sweep"], 2.0 * np.arange(1, 101))
    assert chain.sweeps_done == 200
    # The last sample is the chain's current state, measured here independently.
    x = chain.positions
    A, V = area_volume(x, chain.network.faces)
    assert s["area_um2"][-1] == pytest.approx(A, rel=1e-12)
    assert s["volume_um3"][-1] == pytest.approx(V, rel=1e-12)
    assert (s["axial_um"][-1], s["transverse_um"][-1]) == rbc.diameters(x)
    m = chain.multipliers
    e, _ = rbc.network_energy(chain.network, x, force_pN=20.0,
                              area_multiplier_pN_per_um=m.area_pN_per_um,
                              volume_multiplier_pN_per_um2=m.volume_pN_per_um2,
                              stiffness_scale=chain.summary()["penalty_scale"])
    # The sampler's fixed-order sums against network_energy's: last bits of a ~2000 pN um sum.
    assert s["energy_pNum"][-1] == pytest.approx(e, rel=1e-10)
    assert np.all((s["acceptance"] >= 0) & (s["acceptance"] <= 1)) and np.all(s["step_um"] > 0)


def test_series_production_means_are_the_summary(chain):
    s, su = chain.series, chain.summary()
    production = s["sweep"] > su["adaptive_sweeps"]
    assert su["adaptive_sweeps"] == 40  # 20 % of the first run's sweeps
    assert su["samples_per_chain"] == int(production.sum()) == 80
    assert su["samples"] == su["chains"] * 80
    kept = slice(su["discarded_transient"], None)
    # Every chain drops the same transient; the pooled mean is the mean of the chain means.
    series = [chain.chain_series(c) for c in range(su["chains"])]
    used = [{k: v[c["sweep"] > su["adaptive_sweeps"]][kept] for k, v in c.items()}
            for c in series]
    for k in ("energy_pNum", "axial_um", "transverse_um", "area_um2", "volume_um3"):
        means = [u[k].mean() for u in used]
        assert su["per_chain"][0][k]["mean"] == pytest.approx(means[0], rel=1e-13), k
        assert su[k]["mean"] == pytest.approx(np.mean(means), rel=1e-13), k
        assert su[k]["std"] == pytest.approx(
            np.concatenate([u[k] for u in used]).std(ddof=1), rel=1e-10), k
    assert su["acceptance"] == pytest.approx(
        np.mean([u["acceptance"].mean() for u in used]), rel=1e-13)
    assert su["thermal_shift_axial_um"] == pytest.approx(
        su["axial_um"]["mean"] - chain.reference_axial_um, rel=1e-10)


def test_series_is_empty_before_the_first_run(small_network):
    mc = rbc.MonteCarlo(small_network, seed=1)
    s = mc.series
    assert all(len(v) == 0 for v in s.values()) and "sweep" in s


# ---- continuum_mesh ----

@pytest.fixture(scope="module")
def continuum_meshes():
    # 20 f^2 triangles for icosphere frequencies f = 5, 7, 10: counts the mesh meets exactly.
    return {n: rbc.continuum_mesh(n) for n in (500, 980, 2000)}


@pytest.mark.parametrize("elements", [500, 980, 2000])
def test_continuum_mesh_is_a_closed_sphere_with_the_elements_asked_for(continuum_meshes,
                                                                       elements):
    m = continuum_meshes[elements]
    x, f = np.asarray(m.positions), np.asarray(m.faces)
    assert f.shape == (elements, 3)
    assert x.shape == (elements // 2 + 2, 3)  # F = 2N - 4
    # Every edge is shared by exactly two faces, in opposite directions (closed, oriented).
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    assert len(np.unique(directed, axis=0)) == len(directed)
    undirected, counts = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    assert np.all(counts == 2)
    # Euler characteristic of a sphere: V - E + F = 2.
    assert len(x) - len(undirected) + len(f) == 2
    # Scaled to enclose the Evans-Fung volume (outward: positive).
    A, V = area_volume(x, f)
    assert V == pytest.approx(EVANS_FUNG_VOLUME_UM3, abs=0.005)
    assert A == pytest.approx(EVANS_FUNG_AREA_UM2, rel=0.01)
    assert m.quality.faces == elements and m.quality.area_um2 == pytest.approx(A, rel=1e-12)


def test_continuum_mesh_area_converges_at_second_order(continuum_meshes):
    # At fixed volume the polyhedral area differs from the smooth surface's by O(h^2) = O(1/F):
    # quadrupling F divides the error by 4 (band [3, 5]: the quoted area's rounding, 0.005 um^2,
    # moves the ratio by < 3 %).
    err = {n: area_volume(np.asarray(m.positions), m.faces)[0] - EVANS_FUNG_AREA_UM2
           for n, m in continuum_meshes.items()}
    assert err[500] > err[980] > err[2000] > 0
    assert 3.0 < err[500] / err[2000] < 5.0
