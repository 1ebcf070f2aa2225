// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// The one channel through which library code reports progress, and the one hook through which
// a caller cancels long work; drivers decide where progress goes (stderr for the CLI, nowhere
// in tests) and what cancels (a signal flag in the CLI, Ctrl-C in Python). Library code never
// prints.
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace rbc {
using ProgressSink = std::function<void(const std::string& message)>;
inline void report(const ProgressSink& sink, const std::string& message) {
  if (sink) sink(message);
}

/// Two kinds of message share the channel: progress (a force, stage or block done: what a user
/// follows) and solver internals (Newton iterates, refactorisations, preconditioner statistics,
/// symmetry checks). Internals start with kDetailIndent; front ends show them on request
/// (`rbc ... --verbose`).
inline constexpr std::string_view kDetailIndent = "  ";
inline bool is_detail(const std::string& message) {
  return message.rfind(kDetailIndent, 0) == 0;
}
/// Reports a solver internal (the message is indented by kDetailIndent).
inline void report_detail(const ProgressSink& sink, const std::string& message) {
  if (sink) sink(std::string(kDetailIndent) + message);
}

/// Cooperative cancellation: long-running drivers and solvers call it between iterations
/// (cheap, a few times per iteration at most); when it returns true they stop by throwing
/// Cancelled. Empty = never cancelled. It lives in the options struct of each driver
/// (LbfgsOptions::cancel, NewtonOptions::cancel, McRunSetup::cancel, ...).
using CancelCheck = std::function<bool()>;

/// Thrown by a driver whose CancelCheck returned true. It is not a failure of the solver:
/// callers (the CLI, the Python package) catch it, remove partial outputs and exit/raise.
struct Cancelled : std::runtime_error {
  Cancelled() : std::runtime_error("cancelled by the caller") {}
};

/// Throws Cancelled when `check` is set and returns true.
inline void throw_if_cancelled(const CancelCheck& check) {
  if (check && check()) throw Cancelled();
}
}  // namespace rbc
