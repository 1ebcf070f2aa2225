# SPDX-License-Identifier: GPL-3.0-or-later
# D_A, D_T at 193 pN (order full, exact contact, quadric fit) against element count, uniform
# icosphere against adapted mesh (size ratios 2 and 3), then the adapted mesh's spread over
# --mesh-seed 0 to 3; one CSV row per run on stdout (docs/validation/adapted-mesh.md).
# Usage: /usr/bin/python3 docs/_static/adapted_mesh_measure.py build/rbc > measure.csv
import json, resource, subprocess, sys
rbc = sys.argv[1]
runs = [("uniform", n, None) for n in (500, 1000, 2000, 4000, 8000, 16000, 32000)]
runs += [("adapted", n, 2) for n in (500, 1000, 2000, 4000, 8000, 16000, 32000)]
runs += [("adapted", n, 3) for n in (500, 1000, 2000, 4000, 8000)]
runs = [(kind, n, ratio, 0) for kind, n, ratio in runs]
runs += [("adapted", n, 2, seed) for n in (500, 1000, 2000, 4000, 8000) for seed in (1, 2, 3)]
print("mesh,size_ratio,seed,target,elements,vertices,D_A_um,D_T_um,iterations,solve_s,cpu_s")
for kind, n, ratio, seed in runs:
    args = [rbc, "stretch", "--model", "continuum", "--elements", str(n), "--order", "full",
            "--contact-load", "exact-contact", "--measure", "quadric-fit", "--force", "193",
            "--json", "-q"]
    if kind == "adapted":
        args += ["--mesh", "adapted", "--mesh-size-ratio", str(ratio), "--mesh-seed", str(seed)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run(["nice", "-n", "5"] + args, capture_output=True, text=True, check=True,
                         env={"OMP_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"})
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    p = json.loads(out.stdout)["points"][0]
    seed_text = seed if kind == "adapted" else ""
    print(f"{kind},{ratio or ''},{seed_text},{n},{p['elements']},{p['vertices']},"
          f"{p['axial_um']:.6f},{p['transverse_um']:.6f},{p['iterations']},{p['wall_s']:.3f},"
          f"{cpu:.1f}", flush=True)
