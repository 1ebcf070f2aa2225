#!/usr/bin/python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Lists the tests of a ctest build directory by what they run, one name a line.

  .ci/ctest_tests.py BUILD python   tests whose command runs Python (pytest or a python* binary)
  .ci/ctest_tests.py BUILD skip5    of those, the ones with SKIP_RETURN_CODE 5 (pytest's "no
                                    tests collected" must fail, never count as skipped)
  .ci/ctest_tests.py BUILD mpi      tests whose command runs mpirun or mpiexec, or labelled mpi
  .ci/ctest_tests.py BUILD fast S   tests whose average time in the runs ctest has recorded
                                    (Testing/Temporary/CTestCostData.txt) is below S seconds
Used by .ci/run (Python tests must be registered; the fast tests run again in random order) and .ci/sanitize.sh (an instrumented module
cannot be imported by the uninstrumented interpreter, so Python tests run in the normal build;
MPI tests run in a second pass with the slow unwinder, see there).
"""
import json
import os
import subprocess
import sys


def main() -> int:
    build, kind = sys.argv[1], sys.argv[2]
    if kind not in ("python", "skip5", "mpi", "fast"):
        sys.exit(f"ctest_tests.py: unknown kind '{kind}' (python, skip5, mpi, fast)")
    if kind == "fast":
        return fast_tests(build, float(sys.argv[3]))
    out = subprocess.run(["ctest", "--test-dir", build, "--show-only=json-v1"],
                         capture_output=True, text=True, check=True).stdout
    for test in json.loads(out).get("tests", []):
        command = test.get("command", [])
        props = {p["name"]: p["value"] for p in test.get("properties", [])}
        python = any("pytest" in a or os.path.basename(a).startswith("python") for a in command)
        labels = props.get("LABELS", [])
        mpi = ("mpi" in labels or
               any(os.path.basename(a) in ("mpirun", "mpiexec", "orterun") for a in command))
        skip = props.get("SKIP_RETURN_CODE")
        if ((kind == "python" and python) or (kind == "mpi" and mpi) or
                (kind == "skip5" and python and skip is not None and int(skip) == 5)):
            print(test["name"])
    return 0


def fast_tests(build: str, limit_s: float) -> int:
    """Prints the tests whose recorded average cost is below limit_s (a test never run is left
    out: its time is unknown). The cost file has 'name runs average_s' lines, then '---'."""
    path = os.path.join(build, "Testing", "Temporary", "CTestCostData.txt")
    if not os.path.exists(path):
        sys.exit(f"ctest_tests.py: {path} does not exist (run the suite first)")
    with open(path) as f:
        for line in f:
            if line.startswith("---"):
                break
            fields = line.split()
            if len(fields) == 3 and float(fields[2]) < limit_s:
                print(fields[0])
    return 0


if __name__ == "__main__":
    sys.exit(main())
