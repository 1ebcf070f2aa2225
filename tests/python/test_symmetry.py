# SPDX-License-Identifier: GPL-3.0-or-later
"""rbc.stretch(symmetry="mirror"), both models: the points say how each force was solved
(symmetry_order, symmetry_broken), the package gives what `rbc stretch --symmetry mirror` gives,
the mirror-reduced equilibria are the full ones within the force tolerance's effect, and a
buckling soft network leaves the symmetric states."""
import math

import pytest

import rbc
from conftest import run_cli_json

TIMING = {"wall_s"}


def assert_same_records(py, cli):
    assert len(py) == len(cli)
    for p, c in zip(py, cli):
        assert set(p) == set(c)
        for k in sorted(set(c) - TIMING):
            assert p[k] == c[k], f"{k}: python {p[k]!r} != cli {c[k]!r}"


def test_discrete_mirror_equals_the_full_stretch_and_the_cli():
    forces = [0, 88]
    full = rbc.stretch("discrete", forces, vertices=250)
    mirror = rbc.stretch("discrete", forces, vertices=250, symmetry="mirror")
    assert full.converged.all() and mirror.converged.all()
    # Without the option the points carry no symmetry fields (as the CLI's JSON).
    assert all(p.symmetry_order is None for p in full)
    assert "symmetry_order" not in full.to_records()[0]
    # N = 252: the bead patch keeps the mesh's four mirrors; nothing buckles.
    assert [p.symmetry_order for p in mirror] == [4, 4]
    assert [p.symmetry_broken for p in mirror] == [False, False]
    # tests/discrete/test_symmetry.cpp: two equilibria to 1e-3 pN per vertex differ by up to
    # 2 tol sqrt(N) / 18 pN/um ~ 1.8e-3 um (10 x at 0 pN, where a turn about z is free).
    dx = 2e-3 * math.sqrt(full.network.num_vertices) / 18.0
    for a, b, scale in zip(full, mirror, (10, 1)):
        assert b.axial_um == pytest.approx(a.axial_um, abs=scale * dx)
        assert b.transverse_um == pytest.approx(a.transverse_um, abs=scale * dx)
        assert b.residual_pN <= 1e-3  # the full problem's largest net vertex force
    cli = run_cli_json("stretch", "--vertices", "250", "--force", "0,88", "--symmetry", "mirror",
                       "--json", "-q")["points"]
    assert_same_records(mirror.to_records(), cli)


def test_continuum_mirror_points_equal_the_cli():
    res = rbc.stretch("continuum", [0, 50], elements=400, order=2, symmetry="mirror")
    assert res.converged.all()
    assert all(p.symmetry_order in (2, 4) and p.symmetry_broken is False for p in res)
    cli = run_cli_json("stretch", "--model", "continuum", "--order", "2", "--elements", "400",
                       "--force", "0,50", "--symmetry", "mirror", "--json", "-q")["points"]
    assert_same_records(res.to_records(), cli)


def test_buckling_soft_network_is_solved_in_full():
    # The soft corner of the calibration's prior on a coarse network: the symmetric state at
    # 67.6 pN is a saddle (tests/discrete/test_symmetry.cpp), so that force is solved in full.
    soft = rbc.WlcParameters(persistence_nm=25, lmax_nm=364)
    res = rbc.stretch("discrete", [0, 38, 67.6], vertices=250, wlc=soft, symmetry="mirror")
    assert res.converged.all()
    assert [p.symmetry_order for p in res] == [4, 4, 1]
    assert [p.symmetry_broken for p in res] == [False, False, True]


def test_unknown_symmetry_is_a_value_error():
    for model in ("discrete", "continuum"):
        with pytest.raises(ValueError, match="symmetry 'mirrors' is not one of none, mirror"):
            rbc.stretch(model, [0], vertices=150, elements=400, symmetry="mirrors")


@pytest.mark.parametrize("model,size", [("continuum", 500), ("discrete", 250)])
def test_mirror_planes_mesh_keeps_eight_mirrors_and_matches_the_cli(model, size):
    # mesh_orientation='mirror-planes': all three coordinate mirrors, one eighth of the cell.
    kw = {"elements": size} if model == "continuum" else {"vertices": size}
    r = rbc.stretch(model, [0, 88], symmetry="mirror", mesh_orientation="mirror-planes", **kw)
    assert r.converged.all()
    assert [p.symmetry_order for p in r] == [8, 8]
    size_opt = ["--elements", str(size)] if model == "continuum" else ["--vertices", str(size)]
    cli = run_cli_json("stretch", "--model", model, *size_opt, "--force", "0,88", "--symmetry",
                       "mirror", "--mesh-orientation", "mirror-planes", "--json", "-q")["points"]
    assert_same_records(r.to_records(), cli)


def test_mirror_planes_mesh_and_level_patch_parameters():
    a = rbc.rest_shape(252)
    b = rbc.rest_shape(252, orientation="mirror-planes")
    assert a.num_vertices == b.num_vertices
    assert (a.faces == b.faces).all()  # the same icosphere, laid another way
    assert abs(a.positions - b.positions).max() > 0.1
    c = rbc.ContactParameters(level_patch=True)
    assert c.level_patch and "level_patch=True" in repr(c)
    import pickle
    assert pickle.loads(pickle.dumps(c)).level_patch
    assert not rbc.ContactParameters().level_patch
    with pytest.raises(ValueError, match="mirror-planes"):
        rbc.rest_shape(252, orientation="mirror")
    with pytest.raises(ValueError, match="mesh_orientation"):
        rbc.stretch("discrete", [0], network=rbc.Network(a), mesh_orientation="mirror-planes")
