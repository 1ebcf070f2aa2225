#!/usr/bin/python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Write a Surface Evolver datafile (.fe) of the project's continuum p = 2 stretch scene.

Not part of the build or the test suite: a comparison kit (speed against
Surface Evolver, Debian package evolver-nox). See tools/evolver/README.md.

Input: the rest mesh written by `rbc mesh -n N --quality phi-minimised --out DIR`
(DIR/rest_shape.h5: mesh/positions_um, mesh/faces, vertex/vertex_area_um2). That is the
mesh `rbc stretch --model continuum --elements 2N-4` builds (make_continuum_mesh calls
make_rest_shape with the same options).

The energy, in um / pN / pN um (MODEL.md sections 3-4; continuum/continuum_model.hpp):

  E = sum_T Abar_T Psi(I1, I2) + (kappa/2) int H^2 dA - F sum_i share_i x_i
  with total area A and enclosed volume V held at the rest mesh's values.

The p = 2 law with a = I2/2, B = (I2 + 2)^2/4 - J^2, J = 1 + I1 (homogenise/invariant_laws.cpp)

  Psi = 3 [c0 + c1 a + c2 (a^2 + B/2)] + 2 C/(J^q + eta)
      = const + 3/2 (c1 + c2) I2 + 9/8 c2 I2^2 - 3/2 c2 J^2 + 2 C/(J^q + eta),

c_j = V^(j)(1)/j! the Taylor coefficients of the WLC density V (discrete/wlc.cpp),
C = 3 (1 + eta)^2 V'(1) / (2 q) (discrete/steric_energy.cpp), is written EXACTLY with two
Evolver pieces:

* polynomial part: methods linear_elastic and dirichlet_elastic (reference metric in the
  facet attribute form_factors). Evolver 2.70 computes, per reference area (their sum is
  checked against a direct per-facet sum by tools/evolver/check_law.py),
    linear_elastic:   m/(8 (1 + nu)) [(I2^2 + 2 I2 + 2 - 2 J^2) + nu/(1 - nu) I2^2]
    dirichlet_elastic: m (I2 + 2)
  so linear_elastic with m = 8 c2, nu = 1/3 and dirichlet_elastic with m = 3/2 c1 give
  exactly the polynomial part (up to a constant). Not SVK_elastic: its energy is a
  plane-stress condensed formula unlike its manual entry, and its Hessian code multiplies
  the second-derivative term by one factor dC/dx only (Newton then stalls; measured).
* steric part: method facet_general_integral, whose integrand sees the facet's
  normal N = e1 x e2 (x4, x5, x6), |N| = 2 A_T = 2 J Abar, and the facet attribute abar;
  Evolver integrates (1/2) sum_q w_q f, so the integrand is 2 abar 2 C/((|N|/(2 abar))^q
  + eta), constant on the facet (integral_order_2D 1).
  (A first version used one facet_area instance and one function quantity per facet: the
  same energy, but one Hessian took minutes.)

Bending: star_perp_sq_mean_curvature (energy sum_v h_v^2 A_v/3 with h the mean curvature
(c1 + c2)/2) with modulus 2 kappa, i.e. (kappa/2) int (2h)^2 dA: the same continuum energy
as the project's Juelicher discretisation, a different discretisation of it.
Tweezers: vertex_scalar_integral -fpull*x with element_modulus = the signed share of the
project's by-area contact patch (discrete/tweezers.cpp select_tweezer_patch, replicated).
Area: a fixed named quantity (facet_area); volume: a fixed body volume.

Newton: `hessian_seek` steps (Evolver's Newton step with a line search on the energy; plain
`hessian` steps diverge from 0 to 16 pN) until the largest net vertex force, measured as
the velocity of a zero-scale gradient step (v_velocity: the energy gradient with the area
and volume Lagrange terms removed), is below --tolerance pN (the project's continuum
default, 1e-6 pN) and |A/A0 - 1|, |V/V0 - 1| are below --constraint-tolerance (1e-10, the
project's). Each force starts from the previous equilibrium (continuation, as rbc stretch).

Usage: make_fe.py REST_H5 OUT.fe [--commands OUT.cmd] [--forces 0,16,...] [--positions SHAPE_H5]
Then:  evolver-nox-d -x -f OUT.cmd OUT.fe < /dev/null   (lines "RESULT ..." per force)
"""
import argparse
import math
import os
import sys

import h5py
import numpy as np

KB_J_PER_K = 1.38e-23  # core/units.hpp, MODEL.md
PNUM_PER_J = 1e18


def wlc_taylor(lbar_nm, lmax_nm, p_nm, temperature_K):
    """c0, c1, c2 of V(1 + d) = prefactor phi(x0 sqrt(1 + d)) (pN/um), discrete/wlc.cpp."""
    kt = KB_J_PER_K * temperature_K * PNUM_PER_J  # pN um
    lbar, lmax, p = lbar_nm * 1e-3, lmax_nm * 1e-3, p_nm * 1e-3  # um
    x0 = lbar / lmax
    pre = kt * lmax / (2.0 * math.sqrt(3.0) * p * lbar * lbar)
    om = 1.0 - x0
    phi = (3 * x0**2 - 2 * x0**3) / om
    dphi = (6 * x0 - 9 * x0**2 + 4 * x0**3) / om**2
    d2phi = (6 - 12 * x0 + 12 * x0**2 - 4 * x0**3) / om**3
    dx, d2x = x0 / 2.0, -x0 / 4.0  # dx/dd, d2x/dd2 at d = 0
    c0 = pre * phi
    c1 = pre * dphi * dx
    c2 = 0.5 * pre * (d2phi * dx * dx + dphi * d2x)
    return c0, c1, c2


def law_constants(lbar_nm=75.0, lmax_nm=237.75, p_nm=7.5, temperature_K=300.0, q=1.0,
                  eta=0.005):
    """(c0, c1, c2) and the steric constant C = 3 (1 + eta)^2 V'(1)/(2 q) (pN/um)."""
    c = wlc_taylor(lbar_nm, lmax_nm, p_nm, temperature_K)
    return c, 3.0 * (1.0 + eta) ** 2 * c[1] / (2.0 * q)


def psi_p2(c, C, q, eta, i1, i2):
    """The project's p = 2 density (pN/um) at invariants (i1, i2), constants included."""
    c0, c1, c2 = c
    J = 1.0 + i1
    a, B = 0.5 * i2, 0.25 * (i2 + 2.0) ** 2 - J * J
    return 3.0 * (c0 + c1 * a + c2 * (a * a + 0.5 * B)) + 2.0 * C / (J**q + eta)


def tweezer_patch(x, faces, fraction, levels=False):
    """select_tweezer_patch (by_area) of discrete/tweezers.cpp: vertex -> signed share.
    levels: TweezersParameters::keep_equal_x_together (the mirror-planes meshes): vertices at
    the same x (to 1e-8 um) are one level; whole levels up to the target area, then the next
    level with its shares scaled by the fraction that meets the target."""
    af = 0.5 * np.linalg.norm(
        np.cross(x[faces[:, 1]] - x[faces[:, 0]], x[faces[:, 2]] - x[faces[:, 0]]), axis=1)
    a = np.zeros(len(x))
    for k in range(3):
        np.add.at(a, faces[:, k], af / 3.0)
    total = a.sum()
    order = np.argsort(-x[:, 0], kind="stable")
    share = {}
    for side in (0, 1):
        target = fraction * total
        seq = order if side == 0 else order[::-1]
        if levels:
            weight, area, k = {}, 0.0, 0
            while k < len(seq) and area < target * (1.0 - 1e-12):
                end = k + 1
                while end < len(seq) and abs(x[seq[end], 0] - x[seq[k], 0]) <= 1e-8:
                    end += 1
                group = sum(a[v] for v in seq[k:end])
                w = min(1.0, (target - area) / group)
                for v in seq[k:end]:
                    weight[int(v)] = w
                    area += w * a[v]
                k = end
                if w < 1.0:
                    break  # the edge level
            sign = 1.0 if side == 0 else -1.0
            for v, w in weight.items():
                share[v] = sign * w * a[v] / area
            continue
        chosen, area = [], 0.0
        for v in seq:
            if abs(area + a[v] - target) > abs(area - target) and chosen:
                break
            chosen.append(int(v))
            area += a[v]
        k = len(chosen)
        if k < len(seq) and x[seq[k], 0] == x[seq[k - 1], 0]:
            # std::sort in the project is not stable: the cut may differ on a tie.
            print("make_fe.py: warning: tie in x at the contact patch boundary", file=sys.stderr)
        sign = 1.0 if side == 0 else -1.0
        for v in chosen:
            share[v] = sign * a[v] / area
    return share


def write_commands(path, forces, tol_pN, ctol, maxit):
    """The sweep: per force, hessian_seek until converged; one RESULT line per force:
    RESULT force_pN iterations residual_pN D_A_um D_T_um area_drift volume_drift cpu_s energy"""
    c = []
    c.append("hessian_normal off  // move vertices in all directions (in-plane elasticity)")
    c.append("check_increase off")
    c.append("quiet on")
    c.append(f"tol := {tol_pN:.17g}; ctol := {ctol:.17g}; maxit := {maxit}")
    c.append("t0 := 0; its := 0; rmax := 0; da := 0; dv := 0")
    # Zero-scale gradient step: v_velocity = projected net force; also sets the pressures
    # (Lagrange multipliers) that the first hessian needs.
    c.append("resid := { m 0; g 1; rmax := max(vertex, sqrt(v_velocity[1]^2+v_velocity[2]^2"
             "+v_velocity[3]^2)); da := atot.value/area0 - 1; dv := body[1].volume/volume0 - 1; }")
    c.append("solve := { its := 0; resid; while ( (rmax > tol or abs(da) > ctol or abs(dv) > ctol)"
             " and its < maxit ) do { hessian_seek; its += 1; resid; } }")
    c.append('report := { printf "RESULT %g %d %.10e %.12f %.12f %.3e %.3e %.4f %.12g\\n", fpull, its,'
             " rmax, max(vertex,x)-min(vertex,x), max(vertex,y)-min(vertex,y), da, dv,"
             " clock - t0, total_energy; }")
    for f in forces:
        c.append(f"t0 := clock; fpull := {f:.17g}; solve; report")
    c.append('printf "TOTALCLOCK %.3f\\n", clock')
    c.append("quit")
    with open(path + ".tmp", "w") as fh:
        fh.write("\n".join(c) + "\n")
    os.replace(path + ".tmp", path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("rest_h5")
    ap.add_argument("out_fe")
    ap.add_argument("--positions", help="start from these positions (an rbc shape_*.h5)")
    ap.add_argument("--steric", choices=["exact", "none"], default="exact",
                    help="none: diagnostics only (without it the law is not convex at rest)")
    ap.add_argument("--lbar", type=float, default=75.0, help="nm")
    ap.add_argument("--lmax", type=float, default=237.75, help="nm")
    ap.add_argument("--persistence", type=float, default=7.5, help="nm")
    ap.add_argument("--temperature", type=float, default=300.0, help="K")
    ap.add_argument("--q", type=float, default=1.0)
    ap.add_argument("--eta", type=float, default=0.005)
    ap.add_argument("--kappa", type=float, default=2e-19, help="J")
    ap.add_argument("--contact-fraction", type=float, default=0.05)
    ap.add_argument("--level-patch", action="store_true",
                    help="cut the bead patches between x levels (rbc's mirror-planes meshes)")
    ap.add_argument("--bending", choices=["star_perp_sq_mean_curvature", "star_sq_mean_curvature"],
                    default="star_perp_sq_mean_curvature",
                    help="Evolver's discretisation of int h^2 dA (both with Hessians)")
    ap.add_argument("--commands", help="also write the Evolver command file of the sweep")
    ap.add_argument("--forces", default="0,16,38,67.6,87.6,130,172.8,193", help="pN")
    ap.add_argument("--tolerance", type=float, default=1e-6, help="net vertex force, pN")
    ap.add_argument("--constraint-tolerance", type=float, default=1e-10)
    ap.add_argument("--max-iterations", type=int, default=100, help="Newton steps per force")
    args = ap.parse_args()

    with h5py.File(args.rest_h5, "r") as f:
        X = np.array(f["mesh/positions_um"], dtype=float)
        faces = np.array(f["mesh/faces"], dtype=np.int64)
    x = X
    if args.positions:
        with h5py.File(args.positions, "r") as f:
            x = np.array(f["mesh/positions_um"], dtype=float)
            if not np.array_equal(np.array(f["mesh/faces"]), faces):
                sys.exit("make_fe.py: error: --positions mesh does not match the rest mesh")

    c, C = law_constants(args.lbar, args.lmax, args.persistence, args.temperature, args.q,
                         args.eta)
    c0, c1, c2 = c
    le_modulus, le_poisson = 8.0 * c2, 1.0 / 3.0
    dirichlet_modulus = 1.5 * c1
    kappa_pNum = args.kappa * PNUM_PER_J

    # Reference quantities per facet (form factors from the rest mesh).
    e1 = X[faces[:, 1]] - X[faces[:, 0]]
    e2 = X[faces[:, 2]] - X[faces[:, 0]]
    s11 = np.einsum("ij,ij->i", e1, e1)
    s12 = np.einsum("ij,ij->i", e1, e2)
    s22 = np.einsum("ij,ij->i", e2, e2)
    abar = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)
    area0 = abar.sum()
    volume0 = np.einsum("ij,ij->i", X[faces[:, 0]], np.cross(X[faces[:, 1]], X[faces[:, 2]])).sum() / 6.0
    share = tweezer_patch(X, faces, args.contact_fraction, args.level_patch)

    # Edges with orientation: facet k = (e_a, e_b, e_c) head-to-tail.
    edge_id = {}
    edges = []
    facet_edges = []
    for tri in faces:
        row = []
        for k in range(3):
            a, b = int(tri[k]), int(tri[(k + 1) % 3])
            if (a, b) in edge_id:
                row.append(edge_id[(a, b)])
            elif (b, a) in edge_id:
                row.append(-edge_id[(b, a)])
            else:
                edges.append((a, b))
                edge_id[(a, b)] = len(edges)
                row.append(len(edges))
        facet_edges.append(row)

    nf = len(faces)
    out = []
    w = out.append
    w("// Surface Evolver datafile written by tools/evolver/make_fe.py (rbc project).")
    w("// Continuum p = 2 membrane law (exact), Helfrich bending, optical tweezers,")
    w("// total area and volume fixed. Units: um, pN, pN um.")
    w(f"// Taylor coefficients c0 c1 c2 = {c0:.17g} {c1:.17g} {c2:.17g} pN/um; C = {C:.17g} pN/um")
    w(f"// Psi constant dropped from the energy: psi(0,0) = {psi_p2(c, C, args.q, args.eta, 0.0, 0.0):.17g} pN/um")
    w(f"vertices_predicted {len(X) + 10}")
    w(f"edges_predicted {len(edges) + 10}")
    w(f"facets_predicted {nf + 10}")
    w(f"method_instances_predicted {nf + 20}")
    w(f"quantities_predicted {nf + 20}")
    w("parameter fpull = 0  // total bead force F (pN)")
    w(f"parameter area0 = {area0:.17g}  // um^2")
    w(f"parameter volume0 = {volume0:.17g}  // um^3")
    w("define facet attribute form_factors real[3]")
    w("define facet attribute poisson_ratio real")
    w("define facet attribute abar real  // reference area (um^2)")
    w("define vertex attribute twshare real")
    w("define vertex attribute x0 real")
    w(f"quantity elastic energy modulus {le_modulus:.17g} method linear_elastic global")
    w(f"quantity dirich energy modulus {dirichlet_modulus:.17g} method dirichlet_elastic global")
    w(f"quantity bend energy modulus {2.0 * kappa_pNum:.17g} method {args.bending} global")
    w("method_instance twinst method vertex_scalar_integral global element_modulus twshare")
    w("scalar_integrand: -fpull*x")
    w("quantity tweezers energy method twinst")
    w("quantity atot fixed = area0 method facet_area global")
    if args.steric == "exact":
        # x4, x5, x6: the facet's normal e1 x e2, |N| = 2 A_T = 2 J Abar, and Evolver
        # integrates as (1/2) sum_q w_q f (the manual's area example f = |N|); the
        # integrand is constant on the facet, so one cubature point is exact.
        jq = "sqrt(x4^2+x5^2+x6^2)/(2*abar)"
        if args.q != 1.0:
            jq = f"({jq})^{args.q:.17g}"
        w("integral_order_2D 1")
        w(f"quantity steric energy method facet_general_integral global")
        w(f"scalar_integrand: abar*{4.0 * C:.17g}/({jq}+{args.eta:.17g})")
    w("")
    w("vertices")
    for i in range(len(X)):
        s = share.get(i, 0.0)
        w(f"{i + 1} {x[i, 0]:.17g} {x[i, 1]:.17g} {x[i, 2]:.17g} twshare {s:.17g} x0 {X[i, 0]:.17g}")
    w("")
    w("edges")
    for k, (a, b) in enumerate(edges):
        w(f"{k + 1} {a + 1} {b + 1}")
    w("")
    w("faces")
    for k in range(nf):
        ea, eb, ec = facet_edges[k]
        w(f"{k + 1} {ea} {eb} {ec} density 0 form_factors {{{s11[k]:.17g},{s12[k]:.17g},{s22[k]:.17g}}}"
          f" poisson_ratio {le_poisson:.17g} abar {abar[k]:.17g}")
    w("")
    w("bodies")
    ids = [str(k + 1) for k in range(nf)]
    lines = [" ".join(ids[i:i + 24]) for i in range(0, nf, 24)]
    w("1 " + " \\\n".join(lines) + " volume volume0")
    w("")
    with open(args.out_fe + ".tmp", "w") as f:
        f.write("\n".join(out) + "\n")
    os.replace(args.out_fe + ".tmp", args.out_fe)
    if args.commands:
        forces = [float(f) for f in args.forces.split(",")]
        write_commands(args.commands, forces, args.tolerance, args.constraint_tolerance,
                       args.max_iterations)
    print(f"make_fe.py: {len(X)} vertices, {len(edges)} edges, {nf} facets, patch {len(share)} vertices, "
          f"A0 {area0:.6f} um^2, V0 {volume0:.6f} um^3", file=sys.stderr)


if __name__ == "__main__":
    main()
