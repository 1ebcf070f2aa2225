// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The version of this build of rbc, for `rbc --version`, `rbc.__version__` and the records of
// every output. Defined in one generated translation unit (cmake/version.cpp.in, written by
// cmake/rbc_version.cmake at build time), so a new commit recompiles that file only.
#include <string>

namespace rbc {

/// The CMake project version (e.g. "0.1.0"); built from a git checkout that is not exactly at
/// the tag v<version>, followed by "+g<abbreviated commit hash>", and by "-dirty" when tracked
/// files differed from that commit at build time (e.g. "0.1.0+g5a3eb55-dirty"). Outside a
/// checkout (a source archive): the project version alone.
std::string version_string();

}  // namespace rbc
