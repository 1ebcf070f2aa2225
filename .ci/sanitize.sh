#!/usr/bin/env bash
# Sanitizer job: configures build-asan/ (-DRBC_SANITIZE=ON: ASan + LeakSanitizer + UBSan, -O1 -g,
# every finding fatal), builds everything and runs the C++ suite through ctest with leak
# detection on. Python tests are left to the normal build (an instrumented module cannot be loaded
# by the uninstrumented interpreter); MPI tests run in a second pass with the slow unwinder,
# because OpenMPI's libraries have no frame pointers and unload their plugins, so the fast
# unwinder's stacks cannot be matched against .ci/lsan.supp. Heavy cases excluded under ASan:
# .ci/asan_exclude.txt (one ctest regex a line, each with its reason and measured time).
# Usage: .ci/sanitize.sh [extra ctest arguments, e.g. -R discrete]
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
cmake -S . -B build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRBC_SANITIZE=ON "${launcher[@]}" >/dev/null
cmake --build build-asan -j "$jobs" >/dev/null

export OMP_NUM_THREADS="${OMP_NUM_THREADS:-2}" OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
asan="detect_leaks=1:halt_on_error=1:abort_on_error=0:check_initialization_order=1:strict_init_order=1:detect_stack_use_after_return=0"
export LSAN_OPTIONS="suppressions=$PWD/.ci/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
# OpenMPI in containers (as the MPI tests set it too): no cross-memory attach.
export OMPI_MCA_btl_vader_single_copy_mechanism=none

# One regex of excluded tests: the heavy cases (.ci/asan_exclude.txt), Python and MPI tests.
mapfile -t excluded < <(grep -v '^\s*\(#\|$\)' .ci/asan_exclude.txt | sed 's/\s*#.*//')
mapfile -t python < <(/usr/bin/python3 .ci/ctest_tests.py build-asan python)
mapfile -t mpi < <(/usr/bin/python3 .ci/ctest_tests.py build-asan mpi)
regex() {  # names -> ^(a|b)$ with regex characters escaped
  local out="" n
  for n in "$@"; do out+="${out:+|}$(printf '%s' "$n" | sed 's/[][\.*^$()+?{}|]/\\&/g')"; done
  printf '^(%s)$' "$out"
}
exclude=("${excluded[@]}")
((${#python[@]})) && exclude+=("$(regex "${python[@]}")")
((${#mpi[@]})) && exclude+=("$(regex "${mpi[@]}")")
args=(--test-dir build-asan --output-on-failure -j 2 --timeout 1200 --no-tests=error)
if ((${#exclude[@]})); then
  joined=$(IFS='|'; echo "${exclude[*]}")
  args+=(-E "$joined")
fi
echo "sanitize: C++ suite under ASan+UBSan (excluded: ${#excluded[@]} heavy patterns, ${#python[@]} Python, ${#mpi[@]} MPI tests)"
ASAN_OPTIONS="$asan" ctest "${args[@]}" "$@"
if ((${#mpi[@]})); then
  echo "sanitize: ${#mpi[@]} MPI tests under ASan+UBSan (slow unwinder)"
  ASAN_OPTIONS="$asan:fast_unwind_on_malloc=0" \
    ctest --test-dir build-asan --output-on-failure -j 2 --timeout 1200 -R "$(regex "${mpi[@]}")" "$@"
fi
