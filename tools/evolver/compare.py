#!/usr/bin/python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Run the continuum p = 2 force sweep in Surface Evolver and in rbc, one after the other,
and tabulate time, diameters, residual and drift side by side.

Steps (all output under --work):
  1. rbc mesh -n VERTICES --quality phi-minimised --orientation O --out WORK/mesh   (the
     continuum mesh; --orientation mirror-planes also cuts the bead patches between x levels)
  2. make_fe.py -> WORK/scene.fe, WORK/sweep.cmd                  (exact p = 2 law)
  3. /usr/bin/time evolver-nox-d -x -f sweep.cmd scene.fe          -> WORK/evolver.log
  4. /usr/bin/time rbc stretch --model continuum --elements 2N-4 --force ... --out WORK/rbc_<t>t
     with OMP_NUM_THREADS = t for each t in --threads (OMP_WAIT_POLICY=passive)
  5. WORK/comparison.json and WORK/comparison.md

Timing: process wall and CPU (user + sys) from /usr/bin/time, the load average before each
run (uptime), and the solve-only time of each side (rbc: the sum of its per-force wall_s;
Evolver: the sum of its per-force CPU clock). Nothing here is run by CMake or ctest.

Usage: compare.py --rbc PATH/rbc --work DIR [--vertices 2562] [--threads 1,2]
                  [--symmetry none|mirror] [--orientation dimple-vertex|mirror-planes]
                  [--symmetry-check every-force|highest-force]
"""
import argparse
import csv
import json
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
FORCES = "0,16,38,67.6,87.6,130,172.8,193"  # the bench row continuum/sweep8_from_rest


def timed(cmd, env=None, stdout=None):
    """Runs cmd under /usr/bin/time; returns (wall_s, cpu_s, max_rss_kB, returncode)."""
    tf = stdout.name + ".time" if stdout else "/dev/null"
    r = subprocess.run(["/usr/bin/time", "-f", "%e %U %S %M", "-o", tf] + cmd, env=env,
                       stdin=subprocess.DEVNULL, stdout=stdout, stderr=subprocess.STDOUT)
    wall, user, sys_, rss = open(tf).read().split()[-4:]
    return float(wall), float(user) + float(sys_), int(rss), r.returncode


def load_average():
    return open("/proc/loadavg").read().split()[:3]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rbc", required=True)
    ap.add_argument("--work", required=True)
    ap.add_argument("--vertices", type=int, default=2562)
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--forces", default=FORCES)
    ap.add_argument("--evolver", default="evolver-nox-d")
    ap.add_argument("--symmetry", default="none",
                    help="rbc stretch --symmetry (none | mirror: the mirror-symmetric states)")
    ap.add_argument("--symmetry-check", default="every-force",
                    help="rbc stretch --symmetry-check with --symmetry mirror (every-force | "
                         "highest-force: the symmetric equilibria checked to be minima at each "
                         "force, or at the highest force only)")
    ap.add_argument("--orientation", default="dimple-vertex",
                    help="the mesh on both sides (rbc mesh --orientation, rbc stretch "
                         "--mesh-orientation)")
    ap.add_argument("--kappa", default="2e-19", help="bending rigidity (J), both sides")
    ap.add_argument("--bending", default="star_perp_sq_mean_curvature",
                    help="Evolver's bending method (make_fe.py --bending)")
    args = ap.parse_args()
    w = os.path.abspath(args.work)
    os.makedirs(w, exist_ok=True)
    elements = 2 * args.vertices - 4

    subprocess.run([args.rbc, "mesh", "-n", str(args.vertices), "--quality", "phi-minimised",
                    "--orientation", args.orientation, "--out", os.path.join(w, "mesh")],
                   check=True, stdout=subprocess.DEVNULL)
    rest = os.path.join(w, "mesh", "rest_shape.h5")
    fe, cmd = os.path.join(w, "scene.fe"), os.path.join(w, "sweep.cmd")
    subprocess.run([sys.executable, os.path.join(HERE, "make_fe.py"), rest, fe, "--commands", cmd,
                    "--forces", args.forces, "--kappa", args.kappa, "--bending", args.bending]
                   + (["--level-patch"] if args.orientation == "mirror-planes" else []),
                   check=True)

    result = {"vertices": args.vertices, "elements": elements, "forces_pN": args.forces,
              "orientation": args.orientation, "symmetry": args.symmetry,
              "symmetry_check": args.symmetry_check,
              "kappa_J": float(args.kappa), "evolver_bending": args.bending,
              "cpu": open("/proc/cpuinfo").read().count("processor\t:")}

    # Surface Evolver.
    load = load_average()
    with open(os.path.join(w, "evolver.log"), "w") as log:
        # Serial: evolver -p2 refuses this datafile (ERROR 3362, fixed quantity atot "not
        # connected to any mobile vertices").
        wall, cpu, rss, rc = timed([args.evolver, "-x", "-f", cmd, fe], stdout=log)
    ev_points = []
    for m in re.finditer(r"RESULT (\S+) (\d+) (\S+) (\S+) (\S+) (\S+) (\S+) (\S+) (\S+)",
                         open(os.path.join(w, "evolver.log")).read()):
        f, it, res, da, dt, adr, vdr, cpu_s, e = m.groups()
        ev_points.append({"force_pN": float(f), "iterations": int(it), "residual_pN": float(res),
                          "axial_um": float(da), "transverse_um": float(dt),
                          "area_drift": float(adr), "volume_drift": float(vdr),
                          "cpu_s": float(cpu_s), "energy_pNum": float(e)})
    result["evolver"] = {"wall_s": wall, "cpu_s": cpu, "max_rss_kB": rss, "exit": rc,
                         "load_before": load, "solve_cpu_s": sum(p["cpu_s"] for p in ev_points),
                         "points": ev_points}

    # rbc, once per thread count.
    result["rbc"] = {}
    for t in args.threads.split(","):
        env = dict(os.environ, OMP_NUM_THREADS=t, OMP_WAIT_POLICY="passive")
        out = os.path.join(w, f"rbc_{t}t")
        load = load_average()
        with open(out + ".log", "w") as log:
            # --symmetry-check is refused without --symmetry mirror.
            check = (["--symmetry-check", args.symmetry_check] if args.symmetry == "mirror"
                     else [])
            wall, cpu, rss, rc = timed([args.rbc, "stretch", "--model", "continuum", "--elements",
                                        str(elements), "--force", args.forces, "--kappa", args.kappa,
                                        "--symmetry", args.symmetry] + check +
                                       ["--mesh-orientation", args.orientation, "--out", out,
                                        "-q"],
                                       env=env, stdout=log)
        pts = []
        with open(os.path.join(out, "stretch.csv")) as f:
            rows = [r for r in f if not r.startswith("#")]
        for r in csv.DictReader(rows):
            pts.append({k: float(r[k]) for k in ("force_pN", "axial_um", "transverse_um",
                                                 "iterations", "residual_pN", "area_drift",
                                                 "volume_drift", "wall_s", "energy_pNum")})
        result["rbc"][t] = {"wall_s": wall, "cpu_s": cpu, "max_rss_kB": rss, "exit": rc,
                            "load_before": load, "solve_wall_s": sum(p["wall_s"] for p in pts),
                            "points": pts}

    with open(os.path.join(w, "comparison.json"), "w") as f:
        json.dump(result, f, indent=2)

    # Markdown table.
    t0 = args.threads.split(",")[0]
    ev, rb = result["evolver"], result["rbc"][t0]
    md = [f"# Surface Evolver vs rbc continuum p = 2, {args.vertices} vertices, {elements} elements",
          "", "| F (pN) | D_A Evolver | D_A rbc | rel | D_T Evolver | D_T rbc | rel |"
          " it Ev/rbc | residual Ev / rbc (pN) | |dA|,|dV| Ev | |dA|,|dV| rbc |",
          "|---|---|---|---|---|---|---|---|---|---|---|"]
    for pe, pr in zip(ev["points"], rb["points"]):
        rda = pe["axial_um"] / pr["axial_um"] - 1
        rdt = pe["transverse_um"] / pr["transverse_um"] - 1
        md.append(f"| {pe['force_pN']:g} | {pe['axial_um']:.4f} | {pr['axial_um']:.4f} | {rda:+.1e} |"
                  f" {pe['transverse_um']:.4f} | {pr['transverse_um']:.4f} | {rdt:+.1e} |"
                  f" {pe['iterations']}/{int(pr['iterations'])} |"
                  f" {pe['residual_pN']:.1e} / {pr['residual_pN']:.1e} |"
                  f" {abs(pe['area_drift']):.0e}, {abs(pe['volume_drift']):.0e} |"
                  f" {abs(pr['area_drift']):.0e}, {abs(pr['volume_drift']):.0e} |")
    md += ["", "| run | load before | process wall (s) | process CPU (s) | solve (s) |",
           "|---|---|---|---|---|",
           f"| Evolver | {' '.join(ev['load_before'])} | {ev['wall_s']:.2f} | {ev['cpu_s']:.2f} |"
           f" {ev['solve_cpu_s']:.2f} CPU |"]
    for t, r in result["rbc"].items():
        md.append(f"| rbc OMP_NUM_THREADS={t} | {' '.join(r['load_before'])} | {r['wall_s']:.2f} |"
                  f" {r['cpu_s']:.2f} | {r['solve_wall_s']:.2f} wall |")
    for t, r in result["rbc"].items():
        md.append(f"\nCPU ratio Evolver / rbc ({t} thread(s)): {ev['cpu_s'] / r['cpu_s']:.1f};"
                  f" wall ratio {ev['wall_s'] / r['wall_s']:.1f}")
    with open(os.path.join(w, "comparison.md"), "w") as f:
        f.write("\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
