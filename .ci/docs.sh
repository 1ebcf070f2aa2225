#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# The documentation job: builds the Sphinx site with warnings as errors and nitpicky references
# (sphinx-build -E -W --keep-going -n) and runs every shell and Python block of the tutorials,
# checking the numbers their text states (docs/run_snippets.py). The two run side by side (the
# site build is single-threaded). Exit status 0 only if both pass.
#   .ci/docs.sh [BUILD_DIR]      (default build; the targets rbc and rbc_python are built first)
# Installs the documentation's Debian packages if any is missing (apt-get update once first).
# Outputs: BUILD_DIR/docs/html/index.html, BUILD_DIR/docs/sphinx.log, and
# BUILD_DIR/docs/snippets/<page>/ (each block's script, stdout and stderr).
set -euo pipefail
cd "$(dirname "$0")/.."
build=$(realpath -m "${1:-build}")

packages=(python3-sphinx python3-myst-parser python3-breathe doxygen furo
          python3-sphinx-copybutton python3-sphinxcontrib.bibtex)
.ci/apt_install.sh "${packages[@]}"

if [ ! -f "$build/CMakeCache.txt" ]; then
  echo "docs: $build is not a configured build directory (run ./test.sh or cmake first)" >&2
  exit 2
fi
cmake --build "$build" --target rbc rbc_python -j 2

export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
mkdir -p "$build/docs"
start=$SECONDS
RBC_BUILD_DIR="$build" /usr/bin/python3 -m sphinx -E -W --keep-going -n -q -b html \
  -d "$build/docs/doctrees" docs "$build/docs/html" >"$build/docs/sphinx.log" 2>&1 &
site=$!
src=0
/usr/bin/python3 docs/run_snippets.py --build "$build" || src=$?
echo "docs: snippets $( ((src == 0)) && echo passed || echo FAILED ) in $((SECONDS - start)) s"
rc=0
wait "$site" || rc=$?
cat "$build/docs/sphinx.log"
echo "docs: site $( ((rc == 0)) && echo built || echo FAILED ) in $((SECONDS - start)) s" \
  "-> $build/docs/html/index.html"
((rc == 0 && src == 0))
