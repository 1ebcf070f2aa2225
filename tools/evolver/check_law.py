#!/usr/bin/python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Check that the Evolver datafile of make_fe.py carries the project's p = 2 law exactly.

At a deformed shape written by `rbc stretch --model continuum --out DIR` (DIR/shape_*.h5),
evaluates in Surface Evolver the in-plane terms (linear_elastic + dirichlet_elastic, the
steric facet_general_integral) and the tweezers term, and compares each with a direct sum
over the facets of the project's formula (homogenise/invariant_laws.cpp), evaluated here in
numpy from the rest and deformed positions. Independent truth for the polynomial part is
the law itself; the per-facet invariants are recomputed from the metrics (continuum/
membrane_element.hpp). Exit 1 if any term differs by more than 1e-9 relative.

Usage: check_law.py REST_H5 SHAPE_H5 FORCE_pN [--evolver evolver-nox-d]
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_fe  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("rest_h5")
    ap.add_argument("shape_h5")
    ap.add_argument("force_pN", type=float)
    ap.add_argument("--evolver", default="evolver-nox-d")
    ap.add_argument("--rbc", help="also compare psi_p2 with `rbc psi --order 2 --deformation`")
    args = ap.parse_args()
    ok = True
    if args.rbc:
        # The numpy density against the project's own, at three deformation gradients.
        c, C = make_fe.law_constants()
        for Fd in ((1.1, 0.05, 0.0, 0.95), (1.4, 0.0, 0.0, 0.8), (0.9, -0.2, 0.1, 1.3)):
            out = subprocess.run([args.rbc, "psi", "--order", "2", "--deformation",
                                  ",".join(map(str, Fd))], capture_output=True, text=True).stdout
            have = float(re.search(r"Psi = ([-+0-9.eE]+)", out).group(1))
            Fm = np.array(Fd).reshape(2, 2)
            want = make_fe.psi_p2(c, C, 1.0, 0.005, np.linalg.det(Fm) - 1.0,
                                  (Fm * Fm).sum() - 2.0)
            rel = abs(have - want) / abs(want)
            ok = ok and rel < 1e-8  # rbc psi prints 10 significant digits
            print(f"psi F={Fd}: rbc {have:.10g}  numpy {want:.10g}  rel {rel:.1e}")

    with h5py.File(args.rest_h5, "r") as f:
        X = np.array(f["mesh/positions_um"], dtype=float)
        F = np.array(f["mesh/faces"], dtype=np.int64)
    with h5py.File(args.shape_h5, "r") as f:
        x = np.array(f["mesh/positions_um"], dtype=float)

    q, eta = 1.0, 0.005
    c, C = make_fe.law_constants(q=q, eta=eta)

    def metric(P):
        e1, e2 = P[F[:, 1]] - P[F[:, 0]], P[F[:, 2]] - P[F[:, 0]]
        g12 = np.einsum("ij,ij->i", e1, e2)
        return np.stack([np.stack([np.einsum("ij,ij->i", e1, e1), g12], -1),
                         np.stack([g12, np.einsum("ij,ij->i", e2, e2)], -1)], -2)

    G, g = metric(X), metric(x)
    i2 = np.einsum("fij,fji->f", np.linalg.inv(G), g) - 2.0
    J = np.sqrt(np.linalg.det(g) / np.linalg.det(G))
    abar = 0.5 * np.sqrt(np.linalg.det(G))
    psi = make_fe.psi_p2(c, C, q, eta, J - 1.0, i2)
    steric = 2.0 * C / (J**q + eta)
    # Polynomial part relative to its rest value; Evolver's pieces carry their own
    # constants at rest: linear_elastic 0, dirichlet_elastic (3/2 c1) tr C = 3 c1 per
    # reference area.
    poly_rest = make_fe.psi_p2(c, C, q, eta, 0.0, 0.0) - 2.0 * C / (1.0 + eta)
    want_poly = (abar * (psi - steric - poly_rest)).sum() + abar.sum() * 3.0 * c[1]
    want_steric = (abar * steric).sum()
    share = make_fe.tweezer_patch(X, F, 0.05)
    want_tw = -args.force_pN * sum(s * x[v, 0] for v, s in share.items())

    with tempfile.TemporaryDirectory() as d:
        fe = os.path.join(d, "s.fe")
        cmd = os.path.join(d, "s.cmd")
        subprocess.run([sys.executable, make_fe.__file__, args.rest_h5, fe, "--positions",
                        args.shape_h5], check=True, stderr=subprocess.DEVNULL)
        with open(cmd, "w") as f:
            f.write(f"fpull := {args.force_pN!r}\n")
            f.write('printf "POLY %.17g\\n", elastic.value + dirich.value\n')
            f.write('printf "STERIC %.17g\\n", steric.value\n')
            f.write('printf "TW %.17g\\n", tweezers.value\n')
            f.write("quit\n")
        out = subprocess.run([args.evolver, "-x", "-f", cmd, fe], stdin=subprocess.DEVNULL,
                             capture_output=True, text=True).stdout
    got = {m.group(1): float(m.group(2))
           for m in re.finditer(r"\b(POLY|STERIC|TW) ([-+0-9.][-+0-9.eE]*)", out)}
    for key, want in (("POLY", want_poly), ("STERIC", want_steric), ("TW", want_tw)):
        have = got.get(key, float("nan"))
        rel = abs(have - want) / max(abs(want), 1e-300)
        ok = ok and rel < 1e-9
        print(f"{key:7s} evolver {have:.15g}  direct {want:.15g}  rel {rel:.2e}")
    print("law check:", "ok" if ok else "MISMATCH")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
