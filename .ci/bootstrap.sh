#!/usr/bin/env bash
# SPDX-License-Identifier: GPL-3.0-or-later
# Shared by ./run.sh and ./test.sh: installs the Debian packages the build needs (only those
# missing), then configures and builds in ./build (Release). Usage:
#   .ci/bootstrap.sh [targets...]          the whole project's packages (tests, Python package,
#                                          fuzzing); configured with the tests and the Python
#                                          package on; no targets: builds everything
#   .ci/bootstrap.sh --lean [targets...]   only the packages the `rbc` executable needs; a new
#                                          build/ is configured without the tests and the Python
#                                          package, an existing one keeps its choice (a ./run.sh
#                                          after ./test.sh does not drop the tests)
set -euo pipefail
cd "$(dirname "$0")/.."
lean=0
if [ "${1:-}" = "--lean" ]; then
  lean=1
  shift
fi

# What `rbc` links and runs: compilers, the libraries, OpenBLAS's OpenMP build (the one the
# BLAS thread tests assume), gnuplot (rbc fig7 and tradeoff plot through it), Python with
# numpy, h5py, meshio and matplotlib (the pictures of cells: rbc render), Google Benchmark
# (rbc bench) and Open MPI (rbc infer under mpirun).
packages=(build-essential cmake pkg-config libeigen3-dev libcgal-dev libgsl-dev libhdf5-dev
          libcli11-dev nlohmann-json3-dev libbenchmark-dev libsuitesparse-dev libopenblas0-openmp
          gnuplot-nox python3-numpy python3-h5py python3-meshio python3-matplotlib
          libopenmpi-dev openmpi-bin)
if ((!lean)); then
  # The test suite, the Python package and its tests (the install check makes a virtual
  # environment: venv, setuptools, wheel), the fuzz targets (clang with libFuzzer and its
  # sanitizer runtimes) and the documentation.
  packages+=(libgtest-dev libgmock-dev pybind11-dev python3-dev python3-scipy
             python3-pytest python3-emcee
             python3-venv python3-setuptools python3-wheel
             clang libfuzzer-14-dev libclang-rt-14-dev
             # the documentation site (docs/, .ci/docs.sh)
             python3-sphinx python3-myst-parser python3-breathe doxygen furo
             python3-sphinx-copybutton python3-sphinxcontrib.bibtex)
fi
.ci/apt_install.sh "${packages[@]}"

options=(-DCMAKE_BUILD_TYPE=Release)
command -v ccache >/dev/null &&  # ccache when present (not required)
  options+=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
if ((lean)); then
  # Off only where build/ has no choice yet: an option already in the cache stays as it is.
  for option in RBC_BUILD_TESTS RBC_BUILD_PYTHON; do
    grep -qs "^$option:" build/CMakeCache.txt || options+=("-D$option=OFF")
  done
else
  options+=(-DRBC_BUILD_TESTS=ON -DRBC_BUILD_PYTHON=ON)
fi
jobs=$(nproc 2>/dev/null || echo 2)
cmake -S . -B build "${options[@]}" >&2
if (($#)); then
  for t in "$@"; do cmake --build build --target "$t" -j "$jobs" >&2; done
else
  cmake --build build -j "$jobs" >&2
fi
