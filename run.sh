#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# The main job with defaults: installs what is missing (apt-get), builds (Release), and
# runs the paper's Fig. 7 comparison (microscopic and continuum models against the optical-tweezers data).
# Only what the `rbc` executable needs is installed and built (no test suite, no Python
# package: ./test.sh adds those).
# Outputs: results/fig7/ (fig7.png, fig7_fit.csv, per-method CSVs, fig7.json).
set -euo pipefail
cd "$(dirname "$0")"
.ci/bootstrap.sh --lean rbc
export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"  # idle OpenMP threads sleep
out="${RBC_OUT:-results/fig7}"
./build/rbc fig7 --out "$out" --force-overwrite "$@"
echo
echo "Fig. 7 written to $out/: fig7.png (plot), fig7_fit.csv (goodness of fit),"
echo "fig7_<method>.csv (curves), experiment_*.csv (the two data sets) and fig7.json (summary)."
