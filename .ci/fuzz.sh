#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Fuzz job: builds the libFuzzer targets of fuzz/ with clang++ in build-fuzz/ (-DRBC_FUZZ=ON) and
# runs each for RBC_FUZZ_SECONDS (default 60) from its committed seed corpus fuzz/corpus/<target>/.
# New inputs go to build-fuzz/corpus/<target>/ (the committed corpus is never written); a crash,
# sanitizer report, uncaught exception, leak, >10 s input or >2 GB leaves its input in
# build-fuzz/artifacts/ and fails the job. Usage: .ci/fuzz.sh [target...]  (default: all)
# Reproduce a finding: build-fuzz/fuzz/<target> build-fuzz/artifacts/<target>-crash-...
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${RBC_FUZZ_SECONDS:-60}"
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S . -B build-fuzz -DRBC_FUZZ=ON -DCMAKE_CXX_COMPILER=clang++ -DCMAKE_BUILD_TYPE=Debug \
  "${launcher[@]}" >/dev/null
cmake --build build-fuzz -j "$(nproc 2>/dev/null || echo 2)" >/dev/null

targets=("$@")
if ((${#targets[@]} == 0)); then
  for exe in build-fuzz/fuzz/fuzz_*; do [ -x "$exe" ] && targets+=("$(basename "$exe")"); done
fi
((${#targets[@]})) || { echo "fuzz: no targets in build-fuzz/fuzz/" >&2; exit 1; }
mkdir -p build-fuzz/artifacts
# One target: fuzzes it, then prints one line; its status goes to build-fuzz/artifacts/<t>.status.
fuzz_one() {
  local t=$1 seeds="fuzz/corpus/$1" log="build-fuzz/artifacts/$1.log" start=$SECONDS runs
  if [ ! -d "$seeds" ]; then
    echo "fuzz: $t has no seed corpus $seeds" >&2
    echo 1 >"build-fuzz/artifacts/$t.status"
    return
  fi
  mkdir -p "build-fuzz/corpus/$t"
  if ASAN_OPTIONS="detect_leaks=1:abort_on_error=1" \
     UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1" \
     "build-fuzz/fuzz/$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
       -print_final_stats=1 -artifact_prefix="build-fuzz/artifacts/$t-" \
       "build-fuzz/corpus/$t" "$seeds" >"$log" 2>&1; then
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || echo '?')
    echo "fuzz: $t clean ($runs inputs in $((SECONDS - start)) s)"
    echo 0 >"build-fuzz/artifacts/$t.status"
  else
    echo "fuzz: $t FAILED after $((SECONDS - start)) s; log $log, input build-fuzz/artifacts/$t-*:" >&2
    grep -E 'ERROR|SUMMARY|runtime error|deadly|Test unit written' "$log" | head -20 >&2 || true
    echo 1 >"build-fuzz/artifacts/$t.status"
  fi
}
# The targets run side by side, one per core (each fuzzer is single-threaded), so the job takes
# about ceil(targets / cores) * RBC_FUZZ_SECONDS.
slots=$(nproc 2>/dev/null || echo 2)
running=0
for t in "${targets[@]}"; do
  rm -f "build-fuzz/artifacts/$t.status"
  fuzz_one "$t" &
  running=$((running + 1))
  if ((running >= slots)); then
    wait -n || true
    running=$((running - 1))
  fi
done
wait
failed=()
for t in "${targets[@]}"; do
  [ "$(cat "build-fuzz/artifacts/$t.status" 2>/dev/null)" = 0 ] || failed+=("$t")
done
if ((${#failed[@]})); then
  echo "fuzz: FAILED: ${failed[*]}" >&2
  exit 1
fi
echo "fuzz: all ${#targets[@]} targets clean (${seconds} s each)"
