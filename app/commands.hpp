// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Sub-command registry of the `rbc` executable. Each add_*_command registers one
// sub-command (options with documented defaults) and, when it is selected on the command
// line, stores its work in `action`; main() runs the action after parsing.
//
// Exit codes: 0 success; 1 a solver did not converge (its residual is printed);
// 2 bad input: an unknown option, a non-physical parameter, a missing or corrupt file,
// an unwritable output directory. Errors print one line "rbc: error: ..." on stderr.
#include <CLI/CLI.hpp>
#include <functional>

namespace rbc::app {

using Action = std::function<int()>;

void add_mesh_command(CLI::App& app, Action& action);
void add_stretch_command(CLI::App& app, Action& action);
void add_relax_command(CLI::App& app, Action& action);
void add_bench_command(CLI::App& app, Action& action);
void add_fig7_command(CLI::App& app, Action& action);
void add_tradeoff_command(CLI::App& app, Action& action);
void add_stability_command(CLI::App& app, Action& action);
void add_report_command(CLI::App& app, Action& action);
void add_mc_command(CLI::App& app, Action& action);
void add_moduli_command(CLI::App& app, Action& action);
void add_psi_command(CLI::App& app, Action& action);
void add_dynamics_command(CLI::App& app, Action& action);
void add_infer_command(CLI::App& app, Action& action);
void add_render_command(CLI::App& app, Action& action);

}  // namespace rbc::app
