# SPDX-License-Identifier: GPL-3.0-or-later
"""The examples run (at small sizes) and say what they should."""
import os
import subprocess
import sys

import numpy as np

EXAMPLES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "examples")


def test_fig7_example_writes_the_figure(tmp_path):
    out = tmp_path / "fig7.png"
    r = subprocess.run([sys.executable, os.path.join(EXAMPLES, "fig7.py"), "--vertices", "150",
                        "--elements", "300", "--force", "0,38,88", "--out", str(out)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    rows = {l.split()[0]: l for l in r.stdout.splitlines() if l.split()[0] in ("discrete",
                                                                               "continuum")}
    assert set(rows) == {"discrete", "continuum"}


def test_fig7_curves_stretch_the_cell(tmp_path):
    sys.path.insert(0, EXAMPLES)
    import fig7

    discrete, continuum = fig7.run(150, 300, [0, 38, 88], str(tmp_path / "f.png"))
    for res in (discrete, continuum):
        assert res.converged.all()
        assert np.all(np.diff(res.axial_um) > 0) and np.all(np.diff(res.transverse_um) < 0)
    # the two scales agree (MODEL.md: within a few % up to 193 pN at full resolution)
    np.testing.assert_allclose(discrete.axial_um, continuum.axial_um, rtol=0.05)
    for path, name in ((fig7.SURESH, "Suresh et al. 2005"), (fig7.MILLS, "Mills et al. 2004")):
        label, d = fig7.load(path)
        assert label.startswith(name)
        assert d["force_pN"][0] == 0 and len(d) >= 10


def test_scipy_example_prints_both_equilibria():
    r = subprocess.run([sys.executable, os.path.join(EXAMPLES, "scipy_minimise.py"), "--vertices",
                        "150", "--force", "40"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert "project's solver" in r.stdout and "scipy L-BFGS-B" in r.stdout
