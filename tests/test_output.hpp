// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Where a test writes its files: a directory of its own inside the build tree, never a fixed
// path under the shared temporary directory (two build trees running their suites at once must
// not meet).
#include <filesystem>
#include <string>

namespace rbc::testing {

/// `<build>/test_output/<name>`, emptied and created: each test passes a name of its own.
inline std::filesystem::path fresh_output_dir(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::path(RBC_BINARY_DIR) / "test_output" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

}  // namespace rbc::testing
