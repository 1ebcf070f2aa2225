#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Install check: `cmake --install` of a built tree, a downstream CMake project against it, and the
# Python package pip-installed into a virtual environment. Usage: .ci/install_check.sh BUILD_DIR
# (a configured and built build directory with the Python package on, as ./test.sh leaves build/).
#   1. installs BUILD_DIR into a fresh prefix BUILD_DIR/install-check/prefix;
#   2. configures, builds and runs examples/downstream against it (find_package(rbc), linking
#      rbc::continuum) and checks what it prints: the version is `rbc --version`'s, the continuum
#      mesh's area is within 1 % of the Evans-Fung area 134.09 um^2 (MODEL.md section 1; the
#      500-element mesh's discretisation error is well inside), and its stretch gives the
#      diameters the installed `rbc stretch` prints for the same input (relative 1e-9: the same
#      library code on one thread; the stretch widens the cell, D_A(88 pN) > D_A(0) + 3 um);
#   3. makes a virtual environment over /usr/bin/python3 (--system-site-packages: Debian's numpy),
#      pip-installs the package with RBC_BUILD_DIR=BUILD_DIR (only the target rbc_python is built
#      there), and checks from outside the source tree that rbc.__version__ is `rbc --version`'s
#      and that rbc.stretch runs a small continuum stretch to the same diameters.
# Exits non-zero on the first failure.
set -euo pipefail
if (($# != 1)); then
  echo "usage: $0 BUILD_DIR" >&2
  exit 2
fi
src=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "$1" && pwd)
work=$build/install-check
prefix=$work/prefix
python=/usr/bin/python3
jobs=$(nproc 2>/dev/null || echo 2)
# One thread: the downstream program, the CLI and the Python package sum in the same order.
export OMP_NUM_THREADS=1 OMP_WAIT_POLICY=passive
fail() {
  echo "install check: FAILED: $*" >&2
  exit 1
}

rm -rf "$work"
mkdir -p "$work"
# The executable and the module first (the version string may have changed since the last
# build: both then relink with the new one).
cmake --build "$build" --target rbc rbc_python -j "$jobs" >/dev/null
version=$("$build/rbc" --version)
echo "install check: rbc --version: $version"

# 1. Install.
cmake --install "$build" --prefix "$prefix" >/dev/null
[ -x "$prefix/bin/rbc" ] || fail "no $prefix/bin/rbc"
[ "$("$prefix/bin/rbc" --version)" = "$version" ] || fail "installed rbc --version differs"
config=$(find "$prefix" -name rbcConfig.cmake -print -quit)
[ -n "$config" ] || fail "no rbcConfig.cmake under $prefix"

# 2. Downstream project against the prefix only (the build tree is not on its search path).
cmake -S "$src/examples/downstream" -B "$work/downstream" -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_BUILD_TYPE=Release >"$work/downstream-configure.log" 2>&1 ||
  { cat "$work/downstream-configure.log" >&2; fail "downstream configure"; }
cmake --build "$work/downstream" -j "$jobs" >"$work/downstream-build.log" 2>&1 ||
  { cat "$work/downstream-build.log" >&2; fail "downstream build"; }
"$work/downstream/rbc_downstream" >"$work/downstream.txt" || fail "rbc_downstream exited $?"
"$prefix/bin/rbc" stretch --model continuum --elements 500 --force 0,88 --json \
  >"$work/cli.json" 2>/dev/null || fail "installed rbc stretch"
"$python" - "$work/downstream.txt" "$work/cli.json" "$version" <<'PY' || fail "downstream output"
import json, sys
lines = open(sys.argv[1]).read().splitlines()
cli_run = json.load(open(sys.argv[2]))
assert cli_run["provenance"]["rbc_version"] == sys.argv[3], cli_run["provenance"]
cli = cli_run["points"]
fields = dict(l.split(" ", 1) for l in lines if not l.startswith("force_pN"))
assert fields["version"] == sys.argv[3], (fields["version"], sys.argv[3])
area, truth = float(fields["area_um2"]), 134.09
assert abs(area / truth - 1) < 0.01, f"mesh area {area} um^2, Evans-Fung {truth} um^2"
points = [l.split() for l in lines if l.startswith("force_pN")]
assert len(points) == len(cli) == 2, (points, len(cli))
for p, c in zip(points, cli):
    f, da, dt = float(p[1]), float(p[3]), float(p[5])
    assert f == c["force_pN"], (f, c["force_pN"])
    for mine, theirs in ((da, c["axial_um"]), (dt, c["transverse_um"])):
        assert abs(mine - theirs) <= 1e-9 * abs(theirs), (f, mine, theirs)
assert float(points[1][3]) > float(points[0][3]) + 3.0, points
print(f"install check: downstream: area {area:.4f} um^2 (Evans-Fung {truth}), "
      f"D_A {points[0][3]} -> {points[1][3]} um at 0 -> 88 pN, as the CLI")
PY

# 3. pip install into a virtual environment, reusing the build (setup.py keeps setuptools' files
# in BUILD_DIR/setuptools: removed first, so that no file of an earlier run is packed).
rm -rf "$build/setuptools"
"$python" -m venv --system-site-packages "$work/venv"
(cd "$src" && RBC_BUILD_DIR="$build" RBC_BUILD_JOBS="$jobs" "$work/venv/bin/python" -m pip install \
  --no-build-isolation --no-index --no-deps --quiet .) >"$work/pip.log" 2>&1 ||
  { cat "$work/pip.log" >&2; fail "pip install"; }
(cd "$work" && "$work/venv/bin/python" - "$work/venv" "$version" "$work/cli.json") \
  <<'PY' || fail "Python package"
import json, os, sys
import rbc
venv, version, cli = sys.argv[1], sys.argv[2], json.load(open(sys.argv[3]))["points"]
assert os.path.realpath(rbc.__file__).startswith(os.path.realpath(venv)), rbc.__file__
assert rbc.__version__ == version, (rbc.__version__, version)
res = rbc.stretch("continuum", forces_pN=[0.0, 88.0], elements=500, check=True)
for p, c in zip(res, cli):
    for mine, theirs in ((p.axial_um, c["axial_um"]), (p.transverse_um, c["transverse_um"])):
        assert abs(mine - theirs) <= 1e-9 * abs(theirs), (p.force_pN, mine, theirs)
print(f"install check: python: rbc {rbc.__version__} from {os.path.dirname(rbc.__file__)}, "
      f"D_A {res.axial_um.tolist()} um at 0, 88 pN, as the CLI")
PY
echo "install check: passed"
