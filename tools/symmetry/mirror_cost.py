#!/usr/bin/env python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Process CPU of a 13-force Mills sweep without and with the mirror symmetry, one thread.

Usage: /usr/bin/python3 tools/symmetry/mirror_cost.py [--rbc build/rbc]

Rows: the trade-off table's cheapest methods at 0.5-5 % (README, "With each method at its
best"). CPU = user + system time of the whole `rbc stretch` process (set-up included), and the
largest relative difference of D_A and D_T between the two runs. Each figure is the smallest
of --repeat runs (default 3), alternating none and mirror.
"""
import argparse
import json
import os
import resource
import subprocess

ROWS = [
    ("discrete N = 500", ["-n", "500"]),
    ("discrete N = 1,000", ["-n", "1000"]),
    ("discrete N = 2,000", ["-n", "2000"]),
    ("continuum p = 2, 500 elements", ["--model", "continuum", "--elements", "500"]),
    ("continuum p = 2, 980 elements", ["--model", "continuum", "--elements", "980"]),
    ("continuum full, 980 elements", ["--model", "continuum", "--order", "full", "--elements", "980"]),
    ("continuum full, 2,000 elements", ["--model", "continuum", "--order", "full", "--elements", "2000"]),
    ("continuum full, 3,920 elements", ["--model", "continuum", "--order", "full", "--elements", "3920"]),
]


def run(rbc, args, symmetry):
    env = dict(os.environ, OMP_NUM_THREADS="1", OMP_WAIT_POLICY="passive")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([rbc, "stretch", *args, "--symmetry", symmetry, "--json"], env=env,
                         capture_output=True, text=True, check=True).stdout
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, json.loads(out)["points"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rbc", default="build/rbc")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    print("| method | none (s) | mirror (s) | ratio | diameters, mirror vs none |")
    print("|---|---|---|---|---|")
    for label, args in ROWS:
        cpu_none = cpu_mirror = float("inf")
        for _ in range(a.repeat):
            c, none = run(a.rbc, args, "none")
            cpu_none = min(cpu_none, c)
            c, mirror = run(a.rbc, args, "mirror")
            cpu_mirror = min(cpu_mirror, c)
        diff = max(abs(m[k] - n[k]) / n[k] for m, n in zip(mirror, none)
                   for k in ("axial_um", "transverse_um"))
        print(f"| {label} | {cpu_none:.2f} | {cpu_mirror:.2f} | {cpu_none / cpu_mirror:.2f} | {diff:.1e} |")


if __name__ == "__main__":
    main()
