// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// What produced an output, and how to repeat it: `--config FILE` for every sub-command, the
// resolved configuration (every option's value, given or default) and the provenance (rbc
// version, command line, date, host, threads, BLAS) that run.json, the CSV files, the HDF5
// attributes and `--json` carry.
//
// A configuration file is a JSON object whose keys are the command's long option names without
// the dashes ({"persistence": 10, "force": [0, 88], "model": "continuum", "json": true}). A
// run's own run.json is one as well: its "config" object holds the options; the keys beside it
// (provenance, status, timings, results) describe the outcome and are ignored. Options given on
// the command line override the file; an unknown key is refused.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace rbc::app {

/// Adds `--config FILE` to `cmd`. Call it right after add_subcommand, before any other option:
/// its callback has to run before the other options' callbacks, so it can give the options the
/// command line left unset their values from the file (CLI11 runs them in the order they were
/// added). A missing, unreadable or malformed file, a value of the wrong kind, a key that names
/// no option of the command, or a run.json of another command is a parse error naming the file
/// and the key (exit 2, before any work).
void add_config_option(CLI::App* cmd);

/// The resolved configuration of `cmd` after parsing: {name: value} for every option of the
/// command and of its option groups except --help and --config: the value given (command line
/// or --config), else the default. Numbers as JSON numbers (integers as integers; a real number
/// is written in the shortest form that reads back as the same double), comma-separated number
/// lists as arrays, choices as their names, flags as booleans, options without a value as null.
/// Fed back through --config it repeats the run.
nlohmann::json resolved_config(const CLI::App& cmd);

/// Where and with what a run was made: {"rbc_version", "command_line" (this process's argv,
/// shell-quoted), "date_utc" (ISO 8601), "host", "openmp_threads", "blas": {"library", "core",
/// "config"}}.
nlohmann::json provenance_json();

/// The record every output carries: {"command": "stretch", "config": resolved_config(cmd),
/// "provenance": provenance_json()}. run.json starts from it; `--json` objects include it.
nlohmann::json run_record(const CLI::App& cmd);

/// Writes DIR/run.json: the record with "status": "finished" (atomically).
void write_run_record(const std::string& dir, const nlohmann::json& record);

/// The record as CSV comment lines (without the "# "): "rbc VERSION: COMMAND LINE",
/// "date_utc ..., host ..., openmp_threads N, blas ...", "config {compact JSON}".
std::vector<std::string> record_comment_lines(const nlohmann::json& record);

/// The record as PNG text chunks: Software (rbc VERSION), Source (the command line), Creation
/// Time (date_utc) and rbc_config (compact JSON of the resolved configuration).
std::vector<std::pair<std::string, std::string>> record_png_text(const nlohmann::json& record);

/// The record as HDF5 string attributes: rbc_version, rbc_command_line, rbc_config (compact
/// JSON of the resolved configuration) and rbc_provenance (compact JSON of the provenance).
std::vector<std::pair<std::string, std::string>> record_attributes(const nlohmann::json& record);

}  // namespace rbc::app
