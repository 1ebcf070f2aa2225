// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
// Small helpers shared by the sub-commands: list parsing, progress to stderr, option checks
// that name the option, output-directory checks, file-name tags.
#include <CLI/CLI.hpp>
#include <functional>
#include <iostream>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/progress.hpp"

namespace rbc::app {

/// Parses a comma-separated list of finite numbers; throws std::invalid_argument naming the
/// option, the bad item and the expectation, e.g. "--force abc: expected a comma-separated
/// list of finite numbers >= 0 (e.g. 0,16,88 in pN)". Negative values are refused unless
/// allow_negative. -0 is read as 0.
std::vector<double> parse_number_list(const std::string& text, const std::string& option,
                                      const std::string& example, bool allow_negative);

/// Parses "--force 0,16,38.5" into forces in pN (finite, >= 0).
std::vector<double> parse_force_list(const std::string& text);

/// Progress sink writing "[elapsed s] message" lines to stderr (quiet = discard); solver
/// internals (core/progress.hpp, is_detail) only when verbose. It formats each line in its own
/// stream, so it never changes std::cerr's number format.
ProgressSink stderr_progress(bool quiet, bool verbose = false);

/// Adds --verbose,-v ("also the solver internals on stderr") to `cmd`, bound to `verbose`.
void add_verbose_flag(CLI::App* cmd, bool& verbose);

/// A library quantity (rbc::InvalidParameter::quantity()) -> the command's option for it,
/// e.g. {"persistence length", "--persistence"}.
using OptionNames = std::map<std::string, std::string>;

/// Runs body; an rbc::InvalidParameter about a quantity in `names` is rethrown as
/// std::invalid_argument("<option> <value>: <quantity> must be <expectation>"), so the error
/// line names the option the user typed. Other exceptions pass unchanged.
int naming_options(const OptionNames& names, const std::function<int()>& body);

/// CLI11 check for an integer option: the whole text is a decimal integer in [lo, hi] (no
/// wrap-around, no clamping, no trailing characters); otherwise the parse fails with
/// "<option> <text>: expected an integer in [lo, hi]" (exit 2).
CLI::Validator integer_in(long long lo, long long hi);
/// As integer_in for an unsigned 64-bit option (a seed): [0, 18446744073709551615].
CLI::Validator unsigned_integer();

/// Name prefix of the validators enum_choice makes.
inline constexpr std::string_view kEnumChoicePrefix = "enum:";

/// CLI11 transform for a choice option parsed once into an enum (bound to an enum-typed
/// variable): the text must be one of the names, spelled as listed; otherwise the parse fails
/// with "<option> <text> not in {a,b}" (exit 2). Help shows "{a,b}"; set the option's default
/// text with ->default_str(name).
template <class E>
CLI::Validator enum_choice(std::vector<std::pair<std::string, E>> names) {
  std::string set = "{";
  for (const auto& [name, value] : names) set += (set.size() > 1 ? "," : "") + name;
  set += "}";
  // The validator's name keeps the value -> name map ("enum:0=discrete;1=continuum"), so the
  // resolved configuration (app/run_config.hpp) writes the name back, not the number.
  std::string map = std::string(kEnumChoicePrefix);
  for (const auto& [name, value] : names)
    map += (map.size() > kEnumChoicePrefix.size() ? ";" : "") +
           std::to_string(static_cast<long long>(value)) + "=" + name;
  return CLI::Validator(
             [names, set](std::string& s) -> std::string {
               for (const auto& [name, value] : names)
                 if (s == name) {
                   s = std::to_string(static_cast<long long>(value));
                   return {};
                 }
               return s + " not in " + set;
             },
             set)
      .name(map);
}

/// CLI11 check for an output path option (--out, --checkpoint): a given value must not be
/// empty; otherwise the parse fails with "<option> '': expected a path" (exit 2).
CLI::Validator nonempty_path();

/// Checks an output directory up front, before any work, creates it and takes it for this
/// process: `option` ('--out') must name a directory, or a path whose nearest existing ancestor
/// is a directory, that is not a symbolic link, can be created and written, and is empty
/// (apart from its lock file) unless `overwrite` or `allow_nonempty` (e.g. it holds the run
/// being resumed). The directory is then locked for this process's lifetime (an exclusive
/// flock on DIR/.rbc.lock that the kernel releases when the process dies, however it dies;
/// the file is removed at a normal exit), so a second rbc process on the same directory is
/// refused: "--out DIR: in use by another rbc process (pid N)". Under mpirun, rank 0 takes the
/// lock and the other ranks (which never write --out) only check. Throws std::invalid_argument
/// "--out DIR: ..." naming the problem (filesystem errors as their strerror text).
void prepare_output_directory(const std::string& dir, bool overwrite, bool allow_nonempty = false,
                              const std::string& option = "--out");

/// Name of the lock file prepare_output_directory keeps in the directory (hidden; it does not
/// count as content).
inline constexpr const char* kOutputLockName = ".rbc.lock";

/// Whether DIR holds nothing but its lock file (or does not exist).
bool output_directory_is_empty(const std::string& dir);
/// Removes DIR if it holds nothing but its lock file (a refused run that created it leaves
/// nothing behind); the lock this process holds on it is released.
void discard_empty_output_directory(const std::string& dir);

/// Checks up front that FILE can be written: it is a regular file or does not exist (a
/// directory, device, FIFO, socket or symbolic link is refused: "<option> FILE: is a FIFO,
/// expected a regular file or nothing"), its directory exists or can be created and is
/// writable; throws std::invalid_argument "<option> FILE: ...".
void check_output_file(const std::string& path, const std::string& option);

/// Runs write_failed (which rewrites a run manifest with status "failed" and the reason);
/// if that throws too (a full disk), removes `manifest_path` instead, so no manifest saying
/// "running" outlives the process. Never throws.
void record_failed_manifest(const std::string& manifest_path,
                            const std::function<void()>& write_failed) noexcept;

/// A number for file names that reads back as the same double, so distinct values never
/// share a name (rbc::number_file_tag, core/io.hpp: 16.01 -> "16.01", 16 -> "16.0" with
/// min_decimals 1, 1e-300 -> "1e-300").
std::string number_tag(double value, int min_decimals);

/// Throws "<option> <list>: values must be distinct, <a> and <b> would write the same files"
/// when two values of the list are equal (their tags would collide).
void require_distinct(const std::vector<double>& values, const std::string& option,
                      const std::string& text);

}  // namespace rbc::app
