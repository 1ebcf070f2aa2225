#!/usr/bin/env bash
# Installs what is missing (apt-get), builds everything (Release) and runs the whole test
# suite through ctest. Exit status is ctest's.
set -euo pipefail
cd "$(dirname "$0")"
.ci/bootstrap.sh
export OMP_NUM_THREADS="${OMP_NUM_THREADS:-2}"
# Idle OpenMP threads sleep instead of spinning: ctest runs two suites at once on 2 cores.
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
ctest --test-dir build --output-on-failure -j 2 --timeout 1200
