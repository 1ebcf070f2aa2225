// SPDX-License-Identifier: GPL-3.0-or-later
#include "app/interrupt.hpp"

#include <pthread.h>
#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstring>
#include <system_error>
#include <thread>

#include "core/io.hpp"

namespace rbc::app {

namespace {

// Process-wide by nature: signals belong to the process. Lock-free atomics only, so that the
// fallback handler (stop_or_flag from a signal handler) stays async-signal-safe.
std::atomic<int> g_signal{0};
std::atomic<bool> g_cancellable{false};
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<bool>::is_always_lock_free);

const char* name_of(int sig) {
  return sig == SIGINT ? "SIGINT" : sig == SIGTERM ? "SIGTERM" : "a signal";
}

/// What a SIGINT or SIGTERM does: the first one to a command that polls only sets the flag;
/// otherwise the temporaries go and the process ends at once. Async-signal-safe (atomics,
/// unlink, write, _exit).
void stop_or_flag(int sig) {
  const int previous = g_signal.exchange(sig);
  if (g_cancellable.load() && previous == 0) return;  // the command stops at its next poll
  remove_live_temporaries();
  const char* name = name_of(sig);
  const char prefix[] = "rbc: interrupted by ";
  (void)!write(STDERR_FILENO, prefix, sizeof prefix - 1);
  (void)!write(STDERR_FILENO, name, std::strlen(name));
  (void)!write(STDERR_FILENO, "\n", 1);
  _exit(128 + sig);
}

extern "C" void on_signal(int sig) {
  stop_or_flag(sig);
}

sigset_t interrupt_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGTERM);
  return set;
}

/// The signal mask main() started with, for the children: a process made by fork() (and then
/// exec: MPI's helper daemons) has no signal thread, so it gets the mask back.
sigset_t g_initial_mask;

extern "C" void restore_mask_in_child() {
  pthread_sigmask(SIG_SETMASK, &g_initial_mask, nullptr);
}

void take_signals() {
  const sigset_t set = interrupt_signals();
  for (;;) {
    int sig = 0;
    if (sigwait(&set, &sig) == 0) stop_or_flag(sig);
  }
}

}  // namespace

void install_interrupt_handlers() {
  const sigset_t set = interrupt_signals();
  pthread_sigmask(SIG_BLOCK, &set, &g_initial_mask);
  pthread_atfork(nullptr, nullptr, restore_mask_in_child);
  try {
    std::thread(take_signals).detach();  // ends with the process
  } catch (const std::system_error&) {
    // No thread to spare: handlers instead (a signal then runs on whichever thread it hits).
    pthread_sigmask(SIG_UNBLOCK, &set, nullptr);
    struct sigaction sa {};
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;  // interrupted reads and writes resume: no spurious I/O errors
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
  }
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
