// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// SIGINT/SIGTERM for the `rbc` executable, through the library's cancel hook
// (core/progress.hpp). Signals are taken on one thread of their own: main() blocks SIGINT and
// SIGTERM before any other thread exists (OpenMP, OpenBLAS, MPI), so every later thread inherits
// the mask, and a dedicated thread accepts them with sigwait(). No handler runs inside another
// library's code, and a handler that a library installs for a while (METIS traps SIGTERM during
// an ordering to longjmp out of its errors) never sees a signal the user sent.
//  - a command that polls (it called make_cancellable(): stretch, mc) sees the first signal as
//    interrupt_check() turning true; its solver throws rbc::Cancelled at the next poll, the
//    command writes what is complete (manifest, final checkpoint), temporaries are removed by
//    unwinding (core/io.hpp TempFile), and main() exits 130 (SIGINT) or 143 (SIGTERM);
//  - a command that does not poll, or any second signal (cleanup taking too long, a phase that
//    does not poll), stops at once: the signal thread unlinks the live temporaries
//    (remove_live_temporaries()), writes "rbc: interrupted by SIGTERM" to stderr and calls
//    _exit(128 + signal).
// Child processes do not keep the block: fork() restores the mask main() started with in the
// child (pthread_atfork), and the shell that popen() starts (gnuplot) clears it.
// A SIGTERM that a thread raises at itself (METIS's error path, GKlib's gk_errexit) stays pending
// on that thread; the sparse Cholesky analysis consumes it and reports the failed ordering
// (core/sparse_cholesky.cpp).
#include <string>

#include "core/progress.hpp"

namespace rbc::app {

/// Blocks SIGINT and SIGTERM in the calling thread and starts the thread that takes them. Call
/// first in main(), before any other thread exists: threads created later inherit the mask.
/// Should the thread not start, handlers installed with sigaction() do the same work.
void install_interrupt_handlers();
/// Declares that the running command polls interrupt_check() and writes its outputs on the
/// way out; until then a signal stops the process at once (after removing temporaries).
void make_cancellable();
/// The CancelCheck every command passes into the options of the library (true once a signal
/// arrived).
CancelCheck interrupt_check();
/// The signal received (SIGINT, SIGTERM), 0 if none.
int interrupt_signal();
/// 128 + signal: 130 for SIGINT, 143 for SIGTERM.
int interrupt_exit_code();
/// "SIGINT" / "SIGTERM" (empty if none): the reason a manifest gives.
std::string interrupt_name();

}  // namespace rbc::app
