// SPDX-License-Identifier: GPL-3.0-or-later
#include "app/interrupt.hpp"

#include <unistd.h>

#include <atomic>
#include <csignal>

#include "core/io.hpp"

namespace rbc::app {

namespace {

// Process-wide by nature: a signal handler can reach nothing else. Lock-free atomics only.
std::atomic<int> g_signal{0};
std::atomic<bool> g_cancellable{false};
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<bool>::is_always_lock_free);

extern "C" void on_signal(int sig) {
  const int previous = g_signal.exchange(sig);
  if (g_cancellable.load() && previous == 0) return;  // the command stops at its next poll
  remove_live_temporaries();                          // async-signal-safe: atomics and unlink
  _exit(128 + sig);
}

}  // namespace

void install_interrupt_handlers() {
  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sa.sa_flags = SA_RESTART;  // interrupted reads and writes resume: no spurious I/O errors
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

void make_cancellable() {
  g_cancellable.store(true);
}

CancelCheck interrupt_check() {
  return [] { return g_signal.load(std::memory_order_relaxed) != 0; };
}

int interrupt_signal() {
  return g_signal.load();
}

int interrupt_exit_code() {
  return 128 + g_signal.load();
}

std::string interrupt_name() {
  switch (g_signal.load()) {
    case SIGINT:
      return "SIGINT";
    case SIGTERM:
      return "SIGTERM";
    case 0:
      return "";
    default:
      return "signal " + std::to_string(g_signal.load());
  }
}

}  // namespace rbc::app
