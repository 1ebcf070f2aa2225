// SPDX-License-Identifier: GPL-3.0-or-later
// Number and force lists on the command line (app/cli_util.cpp, fuzzed by fuzz/fuzz_number_list):
// every comma separates two items, so an empty item ("16," or "16,,38") is refused with exit 2
// before any work, like any other malformed item.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <string>

namespace {

struct CommandRun {
  int exit_code;
  std::string output;  // stdout and stderr
};

CommandRun rbc(const std::string& args) {
  const std::string cmd = std::string(RBC_BINARY_DIR) + "/rbc " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 512> buf{};
  while (fgets(buf.data(), buf.size(), p)) out += buf.data();
  const int status = pclose(p);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, out};
}

TEST(CliLists, EmptyItemsAreRefused) {
  for (const char* forces : {"16,", ",16", "16,,38", "' '"}) {
    const CommandRun r = rbc(std::string("stretch -n 200 --json --force ") + forces);
    EXPECT_EQ(r.exit_code, 2) << forces << ": " << r.output;
    EXPECT_NE(r.output.find("rbc: error:"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("force list"), std::string::npos) << r.output;
  }
}

}  // namespace
