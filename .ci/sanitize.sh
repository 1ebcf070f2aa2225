#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Sanitizer job: configures build-asan/ (-DRBC_SANITIZE=ON: ASan + LeakSanitizer + UBSan, -O1 -g1,
# every finding fatal), builds everything and runs the C++ suite through ctest with leak
# detection on. Python tests are left to the normal build (an instrumented module cannot be loaded
# by the uninstrumented interpreter); MPI tests run in a second pass with the slow unwinder,
# because OpenMPI's libraries have no frame pointers and unload their plugins (and HDF5 has no
# frame pointers either), so the fast unwinder's stacks cannot be matched against .ci/lsan.supp:
# a test goes to the second pass when its command runs mpirun, it has the ctest label "mpi", or it
# matches a regex in .ci/asan_slow_unwind.txt. Heavy cases excluded under ASan:
# .ci/asan_exclude.txt (one ctest regex a line, each with its reason and measured time).
# Usage: .ci/sanitize.sh [extra ctest arguments, e.g. -R discrete]
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
# No Python module: the uninstrumented interpreter could not load an instrumented one.
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRBC_SANITIZE=ON -DRBC_BUILD_PYTHON=OFF \
  "${launcher[@]}" >/dev/null
cmake --build build-asan -j "$jobs" >/dev/null

export OMP_NUM_THREADS="${OMP_NUM_THREADS:-2}" OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
asan="detect_leaks=1:halt_on_error=1:abort_on_error=0:check_initialization_order=1:strict_init_order=1:detect_stack_use_after_return=0"
export LSAN_OPTIONS="suppressions=$PWD/.ci/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# OpenMPI in containers (as the MPI tests set it too): no cross-memory attach.
export OMPI_MCA_btl_vader_single_copy_mechanism=none

# Test lists: heavy cases (excluded), Python tests (excluded), slow-unwinder tests (second pass).
patterns() { grep -v '^\s*\(#\|$\)' "$1" | sed 's/\s*#.*//' || true; }
mapfile -t heavy < <(patterns .ci/asan_exclude.txt)
mapfile -t python < <(/usr/bin/python3 .ci/ctest_tests.py build-asan python)
mapfile -t mpi < <(/usr/bin/python3 .ci/ctest_tests.py build-asan mpi)
mapfile -t mpi_patterns < <(patterns .ci/asan_slow_unwind.txt)
names() {  # names -> ^(a|b)$ with regex characters escaped
  local out="" n
  for n in "$@"; do out+="${out:+|}$(printf '%s' "$n" | sed 's/[][\.*^$()+?{}|]/\\&/g')"; done
  printf '^(%s)$' "$out"
}
join() { local IFS='|'; echo "$*"; }
mpi_regex=("${mpi_patterns[@]}")
((${#mpi[@]})) && mpi_regex+=("$(names "${mpi[@]}")")
exclude=("${heavy[@]}" "${mpi_regex[@]}")
((${#python[@]})) && exclude+=("$(names "${python[@]}")")
common=(--test-dir build-asan --output-on-failure -j 2 --timeout 1200 --label-exclude slow)
first=("${common[@]}" --no-tests=error)
((${#exclude[@]})) && first+=(-E "$(join "${exclude[@]}")")
echo "sanitize: C++ suite under ASan+UBSan (left out: ${#heavy[@]} heavy patterns, ${#python[@]} Python tests, MPI and HDF5-error tests for the second pass)"
ASAN_OPTIONS="$asan" ctest "${first[@]}" "$@"
if ((${#mpi_regex[@]})); then
  echo "sanitize: MPI and HDF5-error tests under ASan+UBSan (slow unwinder)"
  ASAN_OPTIONS="$asan:fast_unwind_on_malloc=0" ctest "${common[@]}" -R "$(join "${mpi_regex[@]}")" "$@"
fi
