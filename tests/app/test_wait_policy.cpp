// SPDX-License-Identifier: GPL-3.0-or-later
// The executable runs with idle OpenMP threads sleeping: started without OMP_WAIT_POLICY, it
// sets OMP_WAIT_POLICY=passive and starts itself again in place (libgomp reads the variable
// before main), seen in the running process's environment; a policy the user sets is kept.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include "test_output.hpp"

namespace rbc {
namespace {

/// Starts `build/rbc mc` for a long run with OMP_WAIT_POLICY = policy (empty: unset); returns
/// the OMP_WAIT_POLICY its running image has ("" when none) once the process has set up its
/// output, then stops it.
std::string running_wait_policy(const std::string& policy, const std::string& out) {
  const std::string rbc = std::string(RBC_BINARY_DIR) + "/rbc";
  const pid_t pid = fork();
  if (pid == 0) {
    if (policy.empty())
      unsetenv("OMP_WAIT_POLICY");
    else
      setenv("OMP_WAIT_POLICY", policy.c_str(), 1);
    setenv("OMP_NUM_THREADS", "1", 1);
    const std::vector<std::string> args = {rbc,         "mc", "-n",    "150", "--sweeps",
                                           "100000000", "-q", "--out", out,   "--no-picture"};
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    execv(rbc.c_str(), argv.data());
    _exit(127);
  }
  std::string found;
  // run.json appears once main() runs the command: by then any re-execution has happened.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (std::chrono::steady_clock::now() < deadline && !std::ifstream(out + "/run.json").good())
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  std::ifstream env("/proc/" + std::to_string(pid) + "/environ", std::ios::binary);
  const std::string all((std::istreambuf_iterator<char>(env)), std::istreambuf_iterator<char>());
  for (std::size_t at = 0; at < all.size();) {
    const std::size_t end = all.find('\0', at);
    const std::string entry = all.substr(at, end == std::string::npos ? end : end - at);
    if (entry.rfind("OMP_WAIT_POLICY=", 0) == 0) found = entry.substr(16);
    if (end == std::string::npos) break;
    at = end + 1;
  }
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  return found;
}

TEST(WaitPolicy, IdleOpenMpThreadsSleepUnlessTheUserChoseOtherwise) {
  const auto dir = testing::fresh_output_dir("wait_policy");
  EXPECT_EQ(running_wait_policy("", (dir / "unset").string()), "passive");
  EXPECT_EQ(running_wait_policy("active", (dir / "active").string()), "active");
}

}  // namespace
}  // namespace rbc
