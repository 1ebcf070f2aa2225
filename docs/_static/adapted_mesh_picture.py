# SPDX-License-Identifier: GPL-3.0-or-later
# The adapted mesh at rest and at 193 pN, seen from above and from the side, with its edges,
# coloured by the Zienkiewicz-Zhu error indicator of the 193 pN solution
# (docs/_static/adapted_mesh_193pN.png). Usage:
#   rbc stretch --model continuum --mesh adapted --elements 2000 --order full \
#       --contact-load exact-contact --measure quadric-fit --force 0,193 --out pic
#   /usr/bin/python3 docs/_static/adapted_mesh_picture.py pic/shape_0.0pN.h5 \
#       pic/shape_193.0pN.h5 docs/_static/adapted_mesh_193pN.png "TITLE"
import sys
import h5py
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
from matplotlib.collections import PolyCollection
import numpy as np

rest_file, loaded_file, out, title = sys.argv[1:5]
def load(f):
    with h5py.File(f, "r") as h:
        x = np.array(h["/mesh/positions_um"]).reshape(-1, 3)
        faces = np.array(h["/mesh/faces"]).reshape(-1, 3)
        eta = np.array(h["/face/error_indicator_pN"]).ravel()
    return x, faces, eta
xr, fr, _ = load(rest_file)
xl, fl, eta = load(loaded_file)
fig, axes = plt.subplots(2, 2, figsize=(11, 6.4), gridspec_kw={"height_ratios": [1.25, 1]})
norm = matplotlib.colors.Normalize(vmin=0, vmax=float(np.percentile(eta, 99.5)))
cmap = matplotlib.cm.viridis
for row, (x, f, colour) in enumerate(((xr, fr, None), (xl, fl, eta))):
    for col, (a, b, depth, label) in enumerate(((0, 1, 2, "seen from above (x, y)"),
                                                (0, 2, 1, "seen from the side (x, z)"))):
        ax = axes[row, col]
        n = np.cross(x[f[:, 1]] - x[f[:, 0]], x[f[:, 2]] - x[f[:, 0]])
        keep = n[:, depth] > 0  # the half facing the viewer
        order = np.argsort(x[f[keep]][:, :, depth].mean(axis=1))
        polys = x[f[keep]][order][:, :, [a, b]]
        if colour is None:
            fc = "0.9"
        else:
            fc = cmap(norm(colour[keep][order]))
        ax.add_collection(PolyCollection(polys, facecolors=fc, edgecolors="0.15", linewidths=0.3))
        ax.set_xlim(x[:, a].min() - 0.3, x[:, a].max() + 0.3)
        ax.set_ylim(x[:, b].min() - 0.3, x[:, b].max() + 0.3)
        ax.set_aspect("equal")
        ax.set_xlabel(["x", "y", "z"][a] + " (um)")
        ax.set_ylabel(["x", "y", "z"][b] + " (um)")
        ax.set_title(("rest shape, " if colour is None else "193 pN, ") + label, fontsize=10)
fig.colorbar(matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap), ax=axes[1, :],
             label="error indicator at 193 pN (pN)", shrink=0.8)
fig.suptitle(title, fontsize=11)
fig.savefig(out, dpi=110)
