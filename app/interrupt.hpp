// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// SIGINT/SIGTERM for the `rbc` executable, through the library's cancel hook
// (core/progress.hpp). The handlers only touch lock-free atomics (async-signal-safe):
//  - a command that polls (it called make_cancellable(): stretch, mc) sees the first signal as
//    interrupt_check() turning true; its solver throws rbc::Cancelled at the next poll, the
//    command writes what is complete (manifest, final checkpoint), temporaries are removed by
//    unwinding (core/io.hpp TempFile), and main() exits 130 (SIGINT) or 143 (SIGTERM);
//  - a command that does not poll, or any second signal (cleanup taking too long, a phase that
//    does not poll), stops at once: the handler unlinks the live temporaries
//    (remove_live_temporaries(), async-signal-safe) and calls _exit(128 + signal).
#include <string>

#include "core/progress.hpp"

namespace rbc::app {

/// Installs the SIGINT and SIGTERM handlers (once, at the start of main()).
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
