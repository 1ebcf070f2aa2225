# SPDX-License-Identifier: GPL-3.0-or-later
"""Pictures of cells (python/rbc/render.py, `rbc render`): the shape files are read as written,
and the picture shows the geometry it was given. The independent truth is an ellipsoid with
semi-axes a > b > c written by this test: seen from above, its drawn outline must have the
aspect ratio a / b; seen obliquely, it must be wider than tall. A renderer that swapped axes,
dropped the per-axis scale or drew the wrong file fails."""
import os
import subprocess

import h5py
import matplotlib.image
import numpy as np
import pytest

from conftest import rbc_executable
from rbc import render


def ellipsoid(a_um, b_um, c_um, n=24):
    """A closed triangulated ellipsoid (latitude-longitude grid): positions (N, 3), faces."""
    theta = np.linspace(0, np.pi, n + 1)[1:-1]
    phi = np.linspace(0, 2 * np.pi, 2 * n, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring = np.stack([a_um * np.sin(t) * np.cos(p), b_um * np.sin(t) * np.sin(p),
                     c_um * np.cos(t)], axis=-1).reshape(-1, 3)
    points = np.vstack([[0, 0, c_um], ring, [0, 0, -c_um]])
    m = 2 * n
    faces = []
    for j in range(m):  # caps
        faces.append([0, 1 + j, 1 + (j + 1) % m])
        last = 1 + (n - 2) * m
        faces.append([len(points) - 1, last + (j + 1) % m, last + j])
    for i in range(n - 2):
        for j in range(m):
            a, b = 1 + i * m + j, 1 + i * m + (j + 1) % m
            faces.append([a, a + m, b])
            faces.append([b, a + m, b + m])
    return points, np.asarray(faces, dtype=np.int32)


def write_shape(path, points, faces, force_pN=None):
    with h5py.File(path, "w") as f:
        f["mesh/positions_um"] = points
        f["mesh/faces"] = faces
        f["vertex/displacement_um"] = np.linalg.norm(points, axis=1)[:, None]
        if force_pN is not None:
            f.attrs["force_pN"] = force_pN


def drawn_panels(image):
    """Width and height (pixels) of each coloured region of an RGB(A) image, left to right.
    The cell and the colour bar are coloured; text and background are grey, so the regions are
    the oblique view, the view from above and the colour bar, separated by grey columns."""
    rgb = image[..., :3]
    ink = rgb.max(axis=-1) - rgb.min(axis=-1) > 0.08
    columns = np.flatnonzero(ink.any(axis=0))
    breaks = np.flatnonzero(np.diff(columns) > 1)
    panels = []
    for run in np.split(columns, breaks + 1):
        rows = np.flatnonzero(ink[:, run].any(axis=1))
        panels.append((run[-1] - run[0] + 1, rows[-1] - rows[0] + 1))
    return panels


def test_the_view_from_above_has_the_ellipsoids_aspect_ratio(tmp_path):
    a, b, c = 6.0, 3.0, 1.5
    write_shape(tmp_path / "e.h5", *ellipsoid(a, b, c), force_pN=50.0)
    shapes = render.read_shapes(str(tmp_path / "e.h5"))
    assert len(shapes) == 1 and "F = 50 pN" in shapes[0].label
    field = render.plot_shapes(shapes, str(tmp_path / "e.png"))
    assert field == "displacement_um"
    panels = drawn_panels(matplotlib.image.imread(tmp_path / "e.png"))
    assert len(panels) == 3  # oblique, from above, colour bar
    (w_oblique, h_oblique), (w_top, h_top), _ = panels
    assert w_top / h_top == pytest.approx(a / b, rel=0.03)
    assert w_oblique > 1.5 * h_oblique


def test_the_diameters_are_rbcs_d_a_and_d_t():
    # The grid holds the ellipsoid's equator points on the x and y axes: D_A = 2a, D_T = 2b.
    points, _ = ellipsoid(6.0, 3.0, 1.5)
    assert render.diameters_um(points) == pytest.approx((12.0, 6.0), rel=1e-12)
    # D_T is the widest extent across x in any direction, not the extent along y: turned by
    # 30 degrees about x, the cell keeps its diameters.
    t = np.radians(30.0)
    turn = np.array([[1, 0, 0], [0, np.cos(t), -np.sin(t)], [0, np.sin(t), np.cos(t)]])
    assert render.diameters_um(points @ turn.T) == pytest.approx((12.0, 6.0), rel=1e-12)
    # Against all pairs of points of an irregular cloud.
    cloud = np.random.default_rng(3).normal(size=(300, 3))
    pairs = np.sqrt(((cloud[:, None, 1:] - cloud[None, :, 1:]) ** 2).sum(axis=-1)).max()
    assert render.diameters_um(cloud)[1] == pytest.approx(pairs, rel=1e-12)


def test_a_vertex_field_is_averaged_over_each_triangles_corners(tmp_path):
    points, faces = ellipsoid(2.0, 2.0, 1.0, n=6)
    write_shape(tmp_path / "s.h5", points, faces)
    shape = render.read_shapes(str(tmp_path / "s.h5"))[0]
    r = np.linalg.norm(points, axis=1)
    np.testing.assert_allclose(shape.face_values("displacement_um"), r[faces].mean(axis=1))
    np.testing.assert_allclose(shape.face_values("height_um"), points[faces, 2].mean(axis=1))
    with pytest.raises(ValueError, match="--field no_such_field: not in .*s.h5"):
        shape.face_values("no_such_field")


def run_rbc(*args):
    return subprocess.run([rbc_executable(), *args], capture_output=True, text=True,
                          timeout=300)


def test_rbc_render_draws_what_rbc_mesh_wrote(tmp_path):
    out = tmp_path / "mesh"
    assert run_rbc("mesh", "--vertices", "300", "--out", str(out)).returncode == 0
    png = tmp_path / "rest.png"
    r = run_rbc("render", str(out / "rest_shape.xdmf"), "--out", str(png), "--field",
                "height_um")
    assert r.returncode == 0, r.stderr
    panels = drawn_panels(matplotlib.image.imread(png))
    assert len(panels) == 3
    w, h = panels[1]
    # The rest shape seen from above is a disc: its outline is as wide as tall.
    assert w / h == pytest.approx(1.0, rel=0.05)
    assert [p for p in os.listdir(tmp_path) if "partial" in p] == []


@pytest.mark.parametrize("args, message", [
    (["missing.xdmf", "--out", "p.png"], "missing.xdmf: expected an existing"),
    (["SHAPE", "--out", "p.jpg"], "p.jpg: expected a file name ending .png"),
    (["SHAPE", "--out", "p.png", "--field", "pressure"], "--field pressure: not in"),
])
def test_rbc_render_refuses_bad_input_with_one_line_and_exit_2(tmp_path, args, message):
    points, faces = ellipsoid(2.0, 2.0, 1.0, n=6)
    write_shape(tmp_path / "s.h5", points, faces)
    args = [str(tmp_path / "s.h5") if a == "SHAPE" else
            str(tmp_path / a) if a.startswith(("missing", "p.")) else a for a in args]
    r = run_rbc("render", *args)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("rbc: error: ") and message in lines[0]
    assert not (tmp_path / "p.png").exists()


def test_an_interrupted_render_leaves_a_whole_picture_or_none(tmp_path):
    """SIGTERM while the picture is drawn: exit 143 and no file (nor a temporary) appears later,
    even from the drawing process rbc started; or, if the picture was already done, exit 0
    and a whole PNG."""
    import signal
    import time

    write_shape(tmp_path / "e.h5", *ellipsoid(6.0, 3.0, 1.5, n=80))
    png = tmp_path / "e.png"
    p = subprocess.Popen([rbc_executable(), "render", str(tmp_path / "e.h5"), "--out", str(png)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    time.sleep(0.4)  # inside the drawing (about 1 s); either outcome below is checked
    p.send_signal(signal.SIGTERM)
    p.communicate(timeout=60)
    time.sleep(2.0)  # time for an orphaned drawing process to finish, had it been left running
    if p.returncode == 0:
        assert png.read_bytes().endswith(b"IEND\xaeB`\x82")
    else:
        assert p.returncode == 143
        assert not png.exists()
    assert [f for f in os.listdir(tmp_path) if "partial" in f] == []
