#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# The developer's test command. Without flags: installs what is missing (apt-get), builds
# everything (Release) in build/ and runs the whole suite through ctest (C++, and the Python and
# MPI tests registered there); exit status is ctest's (an empty suite fails).
#   ./test.sh --sanitize [ctest args]   the sanitizer job only (.ci/sanitize.sh, build-asan/)
#   ./test.sh --fuzz [targets]          the fuzz job only (.ci/fuzz.sh, build-fuzz/, 60 s a target)
#   ./test.sh --ci                      everything CI runs (.ci/run): suite, sanitizers, fuzzing
set -euo pipefail
cd "$(dirname "$0")"
case "${1:-}" in
  --sanitize) shift; exec .ci/sanitize.sh "$@" ;;
  --fuzz) shift; exec .ci/fuzz.sh "$@" ;;
  --ci) shift; exec .ci/run "$@" ;;
  "") ;;
  *) echo "test.sh: unknown option '$1' (expected --sanitize, --fuzz or --ci)" >&2; exit 2 ;;
esac
.ci/bootstrap.sh
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-2}"
# Idle OpenMP threads sleep instead of spinning: ctest runs two suites at once on 2 cores.
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
# Tests labelled "slow" (long reference runs) are left out of the suite; `ctest -L slow` runs them.
ctest --test-dir build --output-on-failure -j 2 --timeout 1200 --no-tests=error --label-exclude slow
