#!/usr/bin/env bash
# Shared by ./run.sh and ./test.sh: install the Debian packages the build needs (only
# those missing), then configure and build in ./build (Release). Usage:
#   .ci/bootstrap.sh [cmake targets...]     (no targets: build everything)
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(build-essential cmake pkg-config libeigen3-dev libcgal-dev libgsl-dev libhdf5-dev
          libcli11-dev nlohmann-json3-dev libgtest-dev libgmock-dev libbenchmark-dev
          libsuitesparse-dev libopenblas0-openmp gnuplot-nox
          # MPI (rbc infer over many machines), the Python package and its tests
          libopenmpi-dev openmpi-bin pybind11-dev python3-dev python3-numpy python3-scipy
          python3-pytest python3-matplotlib python3-meshio python3-emcee python3-h5py
          # fuzz targets (.ci/fuzz.sh): clang with libFuzzer and its sanitizer runtimes
          clang libfuzzer-14-dev libclang-rt-14-dev)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "installing missing packages: ${missing[*]}" >&2
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
fi

jobs=$(nproc 2>/dev/null || echo 2)
launcher=()  # ccache when present (not required)
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "${launcher[@]}" >&2
if (($#)); then
  for t in "$@"; do cmake --build build --target "$t" -j "$jobs" >&2; done
else
  cmake --build build -j "$jobs" >&2
fi
