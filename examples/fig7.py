#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""The paper's Fig. 7 from Python: axial and transverse diameters against the optical-tweezers
force, discrete network and continuum model against the two optical-tweezers data sets in data/
(Suresh et al. 2005 healthy cells, Mills et al. 2004 Fig. 8), plotted with matplotlib.

    PYTHONPATH=build/python /usr/bin/python3 examples/fig7.py --out fig7.png
    (defaults: 2,000 vertices, 4,000 elements, the 13 forces of the data; a few minutes on 2 cores)
"""
import argparse
import os

import numpy as np

import rbc

DATA_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data")
SURESH = os.path.join(DATA_DIR, "suresh2005_healthy_optical_tweezers.csv")
MILLS = os.path.join(DATA_DIR, "mills2004_fig8_optical_tweezers.csv")


def load(path):
    """A stretch-data file (read off a published figure): its label (the '# name:' it declares,
    else the file name) and its table force_pN, axial_um, axial_err_um, transverse_um,
    transverse_err_um (pN, um)."""
    with open(path) as f:
        lines = f.readlines()
    label = os.path.basename(path)
    for line in lines:
        if line.startswith("# name:"):
            label = line[len("# name:"):].strip()
    rows = [line for line in lines if not line.startswith("#")]
    return label, np.genfromtxt(rows, delimiter=",", names=True)


def run(vertices=2000, elements=4000, forces_pN=rbc.DEFAULT_FORCES_PN, out="fig7.png"):
    discrete = rbc.stretch("discrete", forces_pN, vertices=vertices)
    continuum = rbc.stretch("continuum", forces_pN, elements=elements, order=2)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    name, d = load(SURESH)
    ax.errorbar(d["force_pN"], d["axial_um"], yerr=d["axial_err_um"], fmt="ko", ms=4, capsize=2,
                label=name + ", D_A")
    ax.errorbar(d["force_pN"], d["transverse_um"], yerr=d["transverse_err_um"], fmt="ks", ms=4,
                mfc="white", capsize=2, label=name + ", D_T")
    name, d = load(MILLS)
    ax.plot(d["force_pN"], d["axial_um"], "o", color="0.6", mfc="none", ms=4,
            label=name + ", D_A and D_T")
    ax.plot(d["force_pN"], d["transverse_um"], "o", color="0.6", mfc="none", ms=4)
    for res, style, name in ((discrete, "-", f"discrete N = {discrete.network.num_vertices}"),
                             (continuum, "--", f"continuum p = 2, {elements} elements")):
        ax.plot(res.forces_pN, res.axial_um, "C0" + style, label=name + ", D_A")
        ax.plot(res.forces_pN, res.transverse_um, "C3" + style, label=name + ", D_T")
    ax.set_xlabel("total bead force (pN)")
    ax.set_ylabel("diameter (um)")
    ax.set_title("Optical-tweezers stretch (Hartmann 2008 Fig. 7)")
    ax.legend(fontsize=7, loc="center right")
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    plt.close(fig)
    return discrete, continuum


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vertices", type=int, default=2000)
    ap.add_argument("--elements", type=int, default=4000)
    ap.add_argument("--force", default=",".join(f"{f:g}" for f in rbc.DEFAULT_FORCES_PN),
                    help="comma-separated forces (pN)")
    ap.add_argument("--out", default="fig7.png")
    a = ap.parse_args()
    discrete, continuum = run(a.vertices, a.elements, [float(f) for f in a.force.split(",")],
                              a.out)
    for res in (discrete, continuum):
        print(res.model.value, "D_A", np.round(res.axial_um, 3), "D_T",
              np.round(res.transverse_um, 3))
    print("wrote", a.out)


if __name__ == "__main__":
    main()
