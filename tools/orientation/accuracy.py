#!/usr/bin/python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Accuracy and cost of the mirror-planes triangulation (rbc stretch --mesh-orientation
mirror-planes) against the default one, over the 13 Mills forces.

For every size it runs, one after the other, on one thread:
  rbc stretch --model M (--vertices N | --elements E) --force MILLS --symmetry mirror
              --mesh-orientation {dimple-vertex, mirror-planes} --json -q
and computes each run's error as the trade-off table does (data/tradeoff/README.md): the
largest relative error of D_A and D_T over the forces against data/tradeoff/reference.csv
(the network at the full spectrin level, mean over 5 triangulation rotations). Beside it, the
committed table's errors at that size (accuracy_cost.csv, mirror rows): the default mesh's
(error_default) and the worst over the rotations run there (error_all), which is what the
`--accuracy` choice relies on. A mirror-planes mesh is the same icosphere laid another way, so
its error should lie within that spread.

CPU times are the median of --repeat runs (default 3; the two orientations alternate), since
one run on a shared 2-core machine varies by 30 %. Writes OUT (CSV) and prints a markdown
table. Nothing here is run by CMake or ctest.

Usage: accuracy.py --rbc build/rbc [--out data/tradeoff/orientation_mirror_planes.csv]
                   [--continuum 500,980,2000,3920,8000,15680]
                   [--discrete 250,500,1000,2000,4000,8000]
"""
import argparse
import csv
import json
import os
import resource
import subprocess
import sys

MILLS = "0,16,19.5,30.6,38,46.6,67.6,87.6,108.8,130,151,172.8,193"
HERE = os.path.dirname(os.path.abspath(__file__))
DATA = os.path.join(HERE, "..", "..", "data", "tradeoff")


def read_csv(path):
    with open(path) as f:
        return list(csv.DictReader(line for line in f if not line.startswith("#")))


def run(rbc, model, size, orientation):
    """One sweep: (points, CPU seconds of the process)."""
    args = [rbc, "stretch", "--model", model, "--force", MILLS, "--symmetry", "mirror",
            "--mesh-orientation", orientation, "--json", "-q"]
    args += ["--elements", str(size)] if model == "continuum" else ["--vertices", str(size)]
    env = dict(os.environ, OMP_NUM_THREADS="1", OMP_WAIT_POLICY="passive")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run(args, env=env, check=True, capture_output=True, text=True).stdout
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return json.loads(out), cpu


def error(points, reference):
    worst = 0.0
    for p in points:
        r = reference[float(p["force_pN"])]
        worst = max(worst, abs(p["axial_um"] / r[0] - 1), abs(p["transverse_um"] / r[1] - 1))
    return worst


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rbc", required=True)
    ap.add_argument("--out", default=os.path.join(DATA, "orientation_mirror_planes.csv"))
    ap.add_argument("--continuum", default="500,980,2000,3920,8000,15680")
    ap.add_argument("--discrete", default="250,500,1000,2000,4000,8000")
    ap.add_argument("--repeat", type=int, default=3, help="runs per sweep (median CPU)")
    args = ap.parse_args()
    reference = {float(r["force_pN"]): (float(r["axial_um"]), float(r["transverse_um"]))
                 for r in read_csv(os.path.join(DATA, "reference.csv"))}
    table = {(int(r["kind"]), int(r["order"]), int(r["resolution"])): r
             for r in read_csv(os.path.join(DATA, "accuracy_cost.csv")) if r["symmetry"] == "1"}
    rows = []
    jobs = [("continuum", 1, 2, int(e)) for e in args.continuum.split(",") if e] + \
           [("discrete", 0, 0, int(n)) for n in args.discrete.split(",") if n]
    for model, kind, order, size in jobs:
        row = {"kind": kind, "order": order, "resolution": size}
        cpus = {"dv": [], "mp": []}
        for _ in range(args.repeat - 1):  # the timing repeats; the last pass below keeps points
            for orientation, tag in (("dimple-vertex", "dv"), ("mirror-planes", "mp")):
                cpus[tag].append(run(args.rbc, model, size, orientation)[1])
        for orientation, tag in (("dimple-vertex", "dv"), ("mirror-planes", "mp")):
            pts, cpu = run(args.rbc, model, size, orientation)
            cpus[tag].append(cpu)
            cpu = sorted(cpus[tag])[len(cpus[tag]) // 2]
            if not all(p["converged"] for p in pts):
                sys.exit(f"{model} {size} {orientation}: a force did not converge")
            row[f"error_{tag}"] = error(pts, reference)
            row[f"cpu_s_{tag}"] = cpu
            row[f"symmetry_order_{tag}"] = min(p["symmetry_order"] for p in pts)
            row["vertices"] = pts[0]["vertices"]
            print(f"{model} {size} {orientation}: error {row[f'error_{tag}']:.4%}, "
                  f"CPU {cpu:.2f} s, |G| {row[f'symmetry_order_{tag}']}", file=sys.stderr)
        t = table.get((kind, order, size))
        row["table_error_default"] = float(t["error_default"]) if t else float("nan")
        row["table_error_all"] = float(t["error_all"]) if t else float("nan")
        row["table_rotations"] = int(t["rotations"]) if t else 0
        rows.append(row)
    fields = ["kind", "order", "resolution", "vertices", "symmetry_order_dv", "symmetry_order_mp",
              "error_dv", "error_mp", "table_error_default", "table_error_all", "table_rotations",
              "cpu_s_dv", "cpu_s_mp"]
    tmp = args.out + ".tmp"
    with open(tmp, "w", newline="") as f:
        f.write("# mirror-planes triangulation against the default one, 13 Mills forces, "
                "--symmetry mirror, one thread (tools/orientation/accuracy.py)\n"
                "# kind: 0 discrete, 1 continuum; order: 0 full law, 2; error = largest relative "
                "error of D_A and D_T over the forces against reference.csv (fraction)\n"
                "# _dv: dimple-vertex (default mesh), _mp: mirror-planes, both run here; "
                "table_error_default / table_error_all: accuracy_cost.csv's mirror row "
                "(default mesh / worst over its rotations)\n"
                "# cpu_s: process CPU time of the whole sweep (mesh generation included), median "
                f"of {args.repeat} runs\n")
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k]) for k in fields})
    os.replace(tmp, args.out)
    print("| model | size | vertices | |G| default / mirror-planes | error default | error "
          "mirror-planes | table: default / worst of rotations | CPU default / mirror-planes |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        name = "continuum p = 2" if r["kind"] == 1 else "discrete"
        print(f"| {name} | {r['resolution']} | {r['vertices']} | {r['symmetry_order_dv']} / "
              f"{r['symmetry_order_mp']} | {r['error_dv']:.2%} | {r['error_mp']:.2%} | "
              f"{r['table_error_default']:.2%} / {r['table_error_all']:.2%} "
              f"({r['table_rotations']}) | {r['cpu_s_dv']:.2f} / {r['cpu_s_mp']:.2f} s |")


if __name__ == "__main__":
    main()
