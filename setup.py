# SPDX-License-Identifier: GPL-3.0-or-later
"""Builds the rbc Python package with CMake (setuptools drives it; Debian 12 has no
scikit-build): the pure-Python files of python/rbc and the extension rbc._rbc, the CMake target
rbc_python (python/CMakeLists.txt).

    python -m venv --system-site-packages venv    # over /usr/bin/python3 (numpy from Debian)
    venv/bin/python -m pip install --no-build-isolation .

Environment:
  RBC_BUILD_DIR   an existing configured build directory of this source tree (e.g. build, as
                  ./test.sh configures it, with RBC_BUILD_PYTHON on and the same Python): only
                  the target rbc_python is built there and its module copied. Without it, a
                  build of its own is configured in build-python/cmake (Release, no tests).
                  setuptools' own files go to RBC_BUILD_DIR/setuptools (else build-python/).
  RBC_BUILD_JOBS  parallel build jobs (default: the number of CPUs).

The version is the one `rbc --version` prints (cmake/rbc_version.cmake; PEP 440 spells
"0.1.0+g<hash>-dirty" as "0.1.0+g<hash>.dirty" in the package metadata; rbc.__version__ keeps
the executable's spelling).
"""
import os
import re
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = Path(__file__).resolve().parent
# setuptools' own build and metadata directories: inside RBC_BUILD_DIR when given, else
# build-python/ (git ignores build*/); never build/ itself, the CMake build directory of ./run.sh
# and ./test.sh.
BUILD_BASE = (os.path.join(os.environ["RBC_BUILD_DIR"], "setuptools")
              if os.environ.get("RBC_BUILD_DIR") else "build-python")


def cmake_project_version():
    text = (ROOT / "CMakeLists.txt").read_text()
    match = re.search(r"project\(\s*rbc\s+VERSION\s+([0-9][0-9.]*)", text)
    if not match:
        raise RuntimeError("no `project(rbc VERSION x.y.z` in CMakeLists.txt")
    return match.group(1)


def version():
    """The build's version string (cmake/rbc_version.cmake), in PEP 440's normal form."""
    out = subprocess.run(
        ["cmake", f"-DRBC_VERSION_BASE={cmake_project_version()}", f"-DRBC_SOURCE_DIR={ROOT}",
         "-P", str(ROOT / "cmake" / "rbc_version.cmake")],
        check=True, capture_output=True, text=True).stdout.strip()
    base, _, local = out.partition("+")
    return base + ("+" + local.replace("-", ".") if local else "")


def cache_value(cache, name):
    match = re.search(rf"^{name}:[A-Z]+=(.*)$", cache, re.MULTILINE)
    return match.group(1) if match else None


class CMakeBuild(build_ext):
    """Builds rbc._rbc through CMake and copies it where setuptools packs it."""

    def build_extension(self, ext):
        jobs = os.environ.get("RBC_BUILD_JOBS", str(os.cpu_count() or 2))
        given = os.environ.get("RBC_BUILD_DIR")
        if given:
            build_dir = Path(given).resolve()
            self.check_build_dir(build_dir)
        else:
            build_dir = (ROOT / "build-python" / "cmake").resolve()
            configure = ["cmake", "-S", str(ROOT), "-B", str(build_dir),
                         "-DCMAKE_BUILD_TYPE=Release", "-DRBC_BUILD_TESTS=OFF",
                         "-DRBC_BUILD_PYTHON=ON", f"-DPython3_EXECUTABLE={sys.executable}"]
            if shutil.which("ccache"):
                configure += ["-DCMAKE_CXX_COMPILER_LAUNCHER=ccache",
                              "-DCMAKE_C_COMPILER_LAUNCHER=ccache"]
            subprocess.run(configure, check=True)
        subprocess.run(["cmake", "--build", str(build_dir), "--target", "rbc_python", "-j", jobs],
                       check=True)
        module = build_dir / "python" / "rbc" / ("_rbc" + sysconfig.get_config_var("EXT_SUFFIX"))
        if not module.is_file():
            found = sorted(p.name for p in (build_dir / "python" / "rbc").glob("_rbc*"))
            raise RuntimeError(f"{module} was not built (found {found}): the build directory's "
                               f"Python is not this one ({sys.executable})")
        target = Path(self.get_ext_fullpath(ext.name))
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(module, target)

    @staticmethod
    def check_build_dir(build_dir):
        cache_file = build_dir / "CMakeCache.txt"
        if not cache_file.is_file():
            raise RuntimeError(f"RBC_BUILD_DIR={build_dir} is not a configured build directory "
                               "(no CMakeCache.txt): configure it first (./test.sh, or cmake -S . "
                               "-B build), or leave RBC_BUILD_DIR unset")
        cache = cache_file.read_text()
        source = cache_value(cache, "CMAKE_HOME_DIRECTORY")
        if source is None or Path(source).resolve() != ROOT:
            raise RuntimeError(f"RBC_BUILD_DIR={build_dir} is the build directory of {source}, "
                               f"not of {ROOT}")
        if cache_value(cache, "RBC_BUILD_PYTHON") == "OFF":
            raise RuntimeError(f"RBC_BUILD_DIR={build_dir} was configured with "
                               "-DRBC_BUILD_PYTHON=OFF (./run.sh does so): reconfigure it with "
                               "-DRBC_BUILD_PYTHON=ON, or leave RBC_BUILD_DIR unset")


os.makedirs(BUILD_BASE, exist_ok=True)
setup(
    version=version(),
    packages=["rbc"],
    package_dir={"rbc": "python/rbc"},
    ext_modules=[Extension("rbc._rbc", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    options={"build": {"build_base": BUILD_BASE}, "egg_info": {"egg_base": BUILD_BASE}},
    zip_safe=False,
)
