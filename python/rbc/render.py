# SPDX-License-Identifier: GPL-3.0-or-later
"""Pictures of cells: any shape rbc writes (HDF5 + XDMF) drawn to a PNG with matplotlib.

One source for both front ends: ``rbc.plot_shape`` in Python and ``rbc render`` on the command
line (the executable embeds this file and runs it with the Debian ``python3``; it needs numpy,
h5py, meshio and matplotlib, and not the compiled ``rbc`` module).

Each shape is one row of the figure, drawn in two views: oblique (elevation 25 degrees) and from
above (looking down z, the axis of the rest shape; the beads pull along x). Every panel uses one
length scale, so the rows compare directly. Triangles are coloured by one field on one colour
scale for all rows:

- ``tension_max_pN_per_um``: the larger principal tension of each element (continuum shapes),
- ``displacement_um``: each vertex's distance from the rest shape (stretch shapes, averaged over
  a triangle's corners),
- ``displacement_x_um``: the x displacement (Monte Carlo snapshots),
- ``height_um``: z, the default when a file carries none of the above (dynamics frames).

and lit by one light, so the shape reads without the mesh lines.
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import sys
from typing import BinaryIO, Optional, Sequence

import numpy as _np

#: Fields in the order a picture picks them when none is named.
FIELD_PREFERENCE = ("tension_max_pN_per_um", "displacement_um", "displacement_x_um", "height_um")


@dataclasses.dataclass
class Shape:
    """One triangulated surface: positions (N, 3) in um, triangles (F, 3), fields by name."""

    points_um: _np.ndarray
    triangles: _np.ndarray
    label: str
    vertex_fields: dict
    face_fields: dict
    source: str = ""  #: the file it was read from

    def __repr__(self) -> str:
        return (f"Shape({self.label!r}, {len(self.points_um)} vertices, {len(self.triangles)} "
                f"triangles, fields {sorted(self.vertex_fields) + sorted(self.face_fields)})")

    def face_values(self, field: str) -> _np.ndarray:
        """The field per triangle (vertex fields averaged over the three corners)."""
        if field == "height_um":
            return self.points_um[self.triangles, 2].mean(axis=1)
        if field in self.face_fields:
            return _np.asarray(self.face_fields[field], dtype=float).ravel()
        if field in self.vertex_fields:
            values = _np.asarray(self.vertex_fields[field], dtype=float).ravel()
            return values[self.triangles].mean(axis=1)
        raise ValueError(f"--field {field}: not in {self.source or self.label} (it has "
                         f"{', '.join(self.fields())})")

    def fields(self) -> list:
        return sorted(self.vertex_fields) + sorted(self.face_fields) + ["height_um"]


def _label_from_attributes(name: str, attributes) -> str:
    parts = []
    if "force_pN" in attributes:
        parts.append(f"F = {float(attributes['force_pN']):g} pN")
    if "sweep" in attributes:
        parts.append(f"sweep {int(attributes['sweep']):,}")
    if "temperature_K" in attributes:
        parts.append(f"T = {float(attributes['temperature_K']):g} K")
    return ", ".join(parts) if parts else name


def _read_h5_shape(path: str) -> list:
    """A shape file written by rbc (mesh/positions_um, mesh/faces, vertex/*, face/*) or a
    dynamics series (frames/NNNNNN/positions_um, time_s): the first and last frames."""
    import h5py

    name = os.path.basename(path)
    with h5py.File(path, "r") as f:
        if "mesh/faces" not in f:
            raise ValueError(f"{path}: no triangles (/mesh/faces): not a shape written by rbc")
        triangles = _np.asarray(f["mesh/faces"], dtype=_np.int64)
        if "frames" in f:
            keys = sorted(f["frames"].keys())
            times = _np.asarray(f["time_s"]).ravel() if "time_s" in f else None
            shapes = []
            for k in dict.fromkeys([keys[0], keys[-1]]):
                t = f"t = {times[int(k)]:g} s" if times is not None else f"frame {int(k)}"
                shapes.append(Shape(_np.asarray(f[f"frames/{k}/positions_um"]), triangles,
                                    t, {}, {}, path))
            return shapes
        points = _np.asarray(f["mesh/positions_um"])
        vertex = {k: _np.asarray(v) for k, v in f["vertex"].items()} if "vertex" in f else {}
        face = {k: _np.asarray(v) for k, v in f["face"].items()} if "face" in f else {}
        return [Shape(points, triangles, _label_from_attributes(name, f.attrs), vertex, face,
                      path)]


def read_shapes(path: str) -> list:
    """The shapes of one file: an rbc ``.h5`` shape (or dynamics series), or any ``.xdmf``.

    An ``.xdmf`` written by rbc is read through its HDF5 file (which carries the attributes that
    name the load); another ``.xdmf`` is read with meshio (a time series: first and last step).
    Raises ValueError naming the file if it is missing or holds no triangles."""
    if not os.path.isfile(path):
        raise ValueError(f"{path}: no such file")
    base, ext = os.path.splitext(path)
    if ext == ".h5":
        return _read_h5_shape(path)
    if ext != ".xdmf":
        raise ValueError(f"{path}: expected a .xdmf or .h5 shape file")
    if os.path.isfile(base + ".h5"):
        return _read_h5_shape(base + ".h5")
    import meshio

    try:
        mesh = meshio.read(path)
        meshes = [(mesh, os.path.basename(path))]
    except Exception:  # a temporal collection: meshio reads those step by step
        with meshio.xdmf.TimeSeriesReader(path) as reader:
            points, cells = reader.read_points_cells()
            steps = [0, reader.num_steps - 1] if reader.num_steps > 1 else [0]
            meshes = []
            for k in steps:
                t, point_data, cell_data = reader.read_data(k)
                meshes.append((meshio.Mesh(points, cells, point_data, cell_data),
                               f"{os.path.basename(path)} at t = {t:g}"))
    shapes = []
    for m, label in meshes:
        tri = m.cells_dict.get("triangle")
        if tri is None:
            raise ValueError(f"{path}: no triangles")
        faces = {k: v[0] for k, v in m.cell_data.items() if len(v) == 1}
        shapes.append(Shape(_np.asarray(m.points), _np.asarray(tri), label,
                            dict(m.point_data), faces, path))
    return shapes


def diameters_um(points_um: _np.ndarray) -> tuple:
    """(D_A, D_T) as rbc measures them (core/geometry.hpp): D_A = max x - min x, and D_T the
    largest extent perpendicular to x, the diameter of the points projected on the y-z plane
    (the largest distance between two corners of their convex hull)."""
    points = _np.asarray(points_um, dtype=float)
    axial = float(points[:, 0].max() - points[:, 0].min())
    pts = sorted(set(map(tuple, points[:, 1:3])))
    if len(pts) < 2:
        return axial, 0.0

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    hull = []
    for sweep in (pts, pts[::-1]):  # Andrew's monotone chain: lower, then upper hull
        part = []
        for q in sweep:
            while len(part) >= 2 and cross(part[-2], part[-1], q) <= 0:
                part.pop()
            part.append(q)
        hull.extend(part[:-1])
    corners = _np.asarray(hull)
    gaps = corners[:, None, :] - corners[None, :, :]
    return axial, float(_np.sqrt((gaps ** 2).sum(axis=-1).max()))


def _field_label(field: str) -> str:
    """House style: the micro sign, real subscripts, units in parentheses."""
    labels = {
        "tension_max_pN_per_um": "largest principal tension (pN/µm)",
        "tension_min_pN_per_um": "smallest principal tension (pN/µm)",
        "displacement_um": "displacement from rest (µm)",
        "displacement_x_um": "x displacement from rest (µm)",
        "height_um": "height z (µm)",
        "I1": "strain invariant $I_1$",
        "I2": "strain invariant $I_2$",
    }
    return labels.get(field, field.replace("_um", " (µm)").replace("_", " "))


def _project(points_um, elev_deg: float, azim_deg: float):
    """Orthographic camera at elevation and azimuth (degrees, matplotlib's convention): the
    screen coordinates (N, 2) in um and the depth towards the camera (N,)."""
    el, az = _np.radians(elev_deg), _np.radians(azim_deg)
    right = _np.array([-_np.sin(az), _np.cos(az), 0.0])
    up = _np.array([-_np.sin(el) * _np.cos(az), -_np.sin(el) * _np.sin(az), _np.cos(el)])
    towards = _np.array([_np.cos(el) * _np.cos(az), _np.cos(el) * _np.sin(az), _np.sin(el)])
    return _np.stack([points_um @ right, points_um @ up], axis=1), points_um @ towards


def plot_shapes(shapes: Sequence[Shape], out_png: str | os.PathLike | BinaryIO,
                field: Optional[str] = None, title: Optional[str] = None,
                dpi: int = 110, metadata: Optional[dict] = None) -> str:
    """Draws the shapes (one row each, two views) to ``out_png`` (a path or a binary file
    object); returns the field used.

    ``field``: one name of :data:`FIELD_PREFERENCE` or any field the files carry; by default
    the first of :data:`FIELD_PREFERENCE` that every shape has. ``metadata``: PNG text chunks
    (key to text), e.g. what produced the shapes."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import LightSource, Normalize
    from matplotlib.collections import PolyCollection

    if not shapes:
        raise ValueError("no shapes to draw")
    if field is None:
        field = next(f for f in FIELD_PREFERENCE if all(f in s.fields() for s in shapes))
    values = [s.face_values(field) for s in shapes]
    lo = min(float(v.min()) for v in values)
    hi = max(float(v.max()) for v in values)
    if field.startswith("displacement") and field != "displacement_x_um":
        lo = 0.0
    if hi <= lo:
        hi = lo + 1e-12
    norm = Normalize(lo, hi)
    cmap = plt.get_cmap("viridis")
    light = LightSource(azdeg=315, altdeg=45)

    every = _np.vstack([s.points_um for s in shapes])
    centre = 0.5 * (every.max(axis=0) + every.min(axis=0))
    views = (("oblique", 25.0, -60.0), ("seen from above (beads along x)", 90.0, -90.0))
    # One length scale for every panel: each column's limits cover all rows, and the columns'
    # widths are in proportion to their extents.
    spans = []
    for _, elev, azim in views:
        flat = _project(every - centre, elev, azim)[0]
        spans.append((flat.min(axis=0) * 1.03, flat.max(axis=0) * 1.03))
    widths = [hi[0] - lo[0] for lo, hi in spans]
    height = max(hi[1] - lo[1] for lo, hi in spans)
    rows = len(shapes)
    inches_per_um = 8.6 / sum(widths)
    # At least 3.6 inches tall, so the colour bar's label fits beside one row.
    fig = plt.figure(figsize=(10.0, max(3.6, rows * (height * inches_per_um + 0.45) +
                                        (0.4 if title else 0.0))))
    grid = fig.add_gridspec(rows, 2, width_ratios=widths, left=0.01, right=0.86, wspace=0.04,
                            hspace=0.3, bottom=0.02, top=0.9 if title else 0.94)
    for r, (shape, value) in enumerate(zip(shapes, values)):
        polys = shape.points_um[shape.triangles] - centre
        normals = _np.cross(polys[:, 1] - polys[:, 0], polys[:, 2] - polys[:, 0])
        lengths = _np.linalg.norm(normals, axis=1, keepdims=True)
        normals = normals / _np.where(lengths > 0, lengths, 1.0)
        rgb = cmap(norm(value))
        rgb[:, :3] *= (0.55 + 0.45 * light.shade_normals(normals, fraction=0.8))[:, None]
        axial_um, transverse_um = diameters_um(shape.points_um)
        for c, ((view, elev, azim), (lo, hi)) in enumerate(zip(views, spans)):
            ax = fig.add_subplot(grid[r, c])
            flat, depth = _project(polys.reshape(-1, 3), elev, azim)
            flat = flat.reshape(-1, 3, 2)
            # Orthographic projection, triangles drawn farthest first (painter's order by the
            # mean depth of each triangle; exact for the convex parts of a cell).
            order = _np.argsort(depth.reshape(-1, 3).mean(axis=1))
            # Edges in the face colour hide the antialiasing seams between triangles.
            ax.add_collection(PolyCollection(flat[order], facecolors=rgb[order],
                                             edgecolors=rgb[order], linewidths=0.25))
            ax.set(xlim=(lo[0], hi[0]), ylim=(lo[1], hi[1]))
            ax.set_aspect("equal")
            ax.set_axis_off()
            if c == 0:
                ax.set_title(f"{shape.label}: $D_\\mathrm{{A}}$ = {axial_um:.2f} µm, "
                             f"$D_\\mathrm{{T}}$ = {transverse_um:.2f} µm", loc="left",
                             fontsize=10)
            elif r == 0:
                ax.set_title(view, fontsize=9, color="0.4")
    scalar = plt.cm.ScalarMappable(norm=norm, cmap=cmap)
    bar = fig.add_axes([0.88, 0.15, 0.018, 0.7])
    fig.colorbar(scalar, cax=bar, label=_field_label(field))
    if title:
        fig.suptitle(title, fontsize=12)
    fig.savefig(out_png, format="png", dpi=dpi, bbox_inches="tight", pad_inches=0.15,
                metadata=dict(metadata or {}))
    plt.close(fig)
    return field


def plot_shape(files: str | os.PathLike | Sequence[str | os.PathLike],
               out_png: str | os.PathLike | BinaryIO, field: Optional[str] = None,
               title: Optional[str] = None, metadata: Optional[dict] = None) -> str:
    """Draws shape files rbc wrote (one path or a list of .xdmf/.h5) to ``out_png``, as
    ``rbc render`` does; returns the field the triangles are coloured by.

    Example::

        # after `rbc stretch --vertices 1000 --force 0,100 --out run`
        rbc.plot_shape(["run/shape_0.0pN.xdmf", "run/shape_100.0pN.xdmf"], "cell.png")
    """
    paths = [files] if isinstance(files, (str, os.PathLike)) else list(files)
    shapes = [s for path in paths for s in read_shapes(os.fspath(path))]
    target = os.fspath(out_png) if isinstance(out_png, (str, os.PathLike)) else out_png
    return plot_shapes(shapes, target, field=field, title=title, metadata=metadata)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``rbc render FILE... --out PNG [--field NAME] [--title TEXT]``: exit 0, or 2 with one
    line "rbc: error: ..." on bad input."""
    parser = argparse.ArgumentParser(prog="rbc render", add_help=True)
    parser.add_argument("files", nargs="+")
    parser.add_argument("--out", required=True)
    parser.add_argument("--field", default=None)
    parser.add_argument("--title", default=None)
    parser.add_argument("--metadata", action="append", default=[], metavar="KEY=TEXT",
                        help="a PNG text chunk (repeatable)")
    args = parser.parse_args(argv)
    metadata = dict(item.split("=", 1) for item in args.metadata if "=" in item)
    # "--out -": the PNG goes to stdout (rbc render writes the file itself).
    target = sys.stdout.buffer if args.out == "-" else args.out
    try:
        field = plot_shape(args.files, target, field=args.field, title=args.title,
                           metadata=metadata)
    except (ValueError, OSError, KeyError, StopIteration) as error:
        message = str(error) if not isinstance(error, StopIteration) else \
            "the files share no field to colour by"
        print(f"rbc: error: {message}", file=sys.stderr)
        return 2
    if args.out != "-":
        print(f"{args.out}: coloured by {field}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
